// SPDX-License-Identifier: MIT
#include "replay.hpp"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <deque>
#include <memory>

namespace lidarflow::bridge {
namespace {

using EventPtr = std::unique_ptr<LogEvent>;

// Events in log order, read lazily: the look-ahead for late LiDAR sweeps reads only as far as
// the wait reaches, so a long log is never held in memory. The data of events on channels the
// bridge does not take is not read at all.
class LogReader {
public:
    LogReader(EventLogReader *log, const BridgeConfig &config) : log_(log), config_(config) {}
    // The i-th pending event (0 = next), reading as needed; nullptr past the end.
    struct Pending {
        EventPtr event;
        bool fed = false;  // handed over early (look-ahead)
    };
    Pending *peek(size_t i) {
        while (pending_.size() <= i && !eof_) {
            EventPtr e(new LogEvent);
            if (!log_->next(e.get(), &LogReader::wanted, this)) {
                eof_ = true;
                break;
            }
            pending_.push_back({std::move(e), false});
        }
        return i < pending_.size() ? &pending_[i] : nullptr;
    }
    void pop() { pending_.pop_front(); }
    // Events on `channel` not yet handed over: the pending ones, then the rest of the log (read
    // header by header, data left out) until `deadline` [monotonic s]: *complete is false when
    // the count stopped there (a signal must end the replay within a second, whatever is left).
    int64_t count_rest(const std::string &channel, double deadline, bool *complete) {
        int64_t n = 0;
        for (const Pending &p : pending_) n += !p.fed && p.event->channel == channel;
        pending_.clear();
        LogEvent e;
        *complete = true;
        for (int64_t k = 0; !eof_; ++k) {
            if (k % 256 == 0 && monotonic_seconds() > deadline) {
                *complete = false;
                break;
            }
            if (!log_->next(&e, [](const std::string &, void *) { return false; }, nullptr)) break;
            n += e.channel == channel;
        }
        eof_ = true;
        return n;
    }

private:
    static bool wanted(const std::string &channel, void *self) {
        const BridgeConfig &c = static_cast<LogReader *>(self)->config_;
        return channel == c.stereo_channel || channel == c.lidar_channel || channel == c.calibration_channel;
    }
    EventLogReader *log_;
    const BridgeConfig &config_;
    std::deque<Pending> pending_;
    bool eof_ = false;
};

struct Output {
    EventLogWriter *log = nullptr;
    int64_t now = 0;  // log clock: timestamp of the input event being handled
    int64_t flows = 0, status = 0, egos = 0, qualities = 0, failures = 0;
    std::string flow_channel, ego_channel, quality_channel;
};

void write_output(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
    auto *out = static_cast<Output *>(user);
    if (!out->log->write(out->now, channel, rbuf->data, rbuf->data_size)) {
        ++out->failures;
        return;
    }
    if (out->flow_channel == channel) ++out->flows;
    else if (out->ego_channel == channel) ++out->egos;
    else if (out->quality_channel == channel) ++out->qualities;
    else ++out->status;
}

constexpr double kClockJumpUs = 86400e6;  // a day
constexpr int64_t kMaxNotesPerKind = 10;
// LiDAR look-ahead bounds besides --lidar-wait-ms of log time: the live bridge keeps at most
// --lidar-buffer (<= 1000) sweeps, so reading further ahead could not change a pairing.
constexpr size_t kLookaheadEvents = 4096;
constexpr size_t kLookaheadBytes = size_t(64) << 20;

// a > b + d without overflow (log times may sit anywhere in int64).
bool later_than(int64_t a, int64_t b, int64_t d) {
    return static_cast<__int128>(a) > static_cast<__int128>(b) + d;
}

const char *drop_reason(const Counters &a, const Counters &b) {
    if (b.dropped_stale > a.dropped_stale) return "stale";
    if (b.dropped_out_of_order > a.dropped_out_of_order) return "out of order";
    if (b.dropped_no_calibration > a.dropped_no_calibration) return "no calibration";
    if (b.dropped_calibration_mismatch > a.dropped_calibration_mismatch) return "calibration mismatch";
    if (b.dropped_malformed > a.dropped_malformed) return "malformed";
    if (b.dropped_estimator_error > a.dropped_estimator_error) return "estimator error";
    if (b.dropped_shutdown > a.dropped_shutdown) return "shutdown";
    if (b.dropped_unpaired > a.dropped_unpaired) return "unpaired";
    return "?";
}

// The LOST lines of a stereo frame handed to the bridge: what its counters say became of it.
void note_losses(const Counters &before, const Counters &after, const LogEvent &event, std::vector<std::string> *lost) {
    StereoMessage m;
    const bool decodable = decode_stereo(event.data.data(), event.data.size(), m).empty();
    const std::string which =
        decodable ? printf_string("stereo frame utime %" PRId64 " (sequence %d, frame_number %" PRId64
                                  ", log event %" PRId64 ")",
                                  m.msg().utime, m.msg().sequence, m.msg().frame_number, event.event_number)
                  : printf_string("stereo log event %" PRId64, event.event_number);
    if (after.dropped() > before.dropped()) {
        // last_error is this frame's only for the reasons that set it.
        const bool own_error = after.dropped_malformed > before.dropped_malformed ||
                               after.dropped_estimator_error > before.dropped_estimator_error;
        lost->push_back(printf_string("%s dropped: %s%s%s", which.c_str(), drop_reason(before, after),
                                      own_error ? ": " : "", own_error ? after.last_error.c_str() : ""));
    }
    if (after.pairs_lost_calibration_change > before.pairs_lost_calibration_change)
        lost->push_back(printf_string("%s: no result, the calibration changed since the frame before", which.c_str()));
    if (after.stereo_lost_in_transport > before.stereo_lost_in_transport)
        lost->push_back(printf_string("%" PRId64 " frame(s) missing from the log before %s",
                                      after.stereo_lost_in_transport - before.stereo_lost_in_transport, which.c_str()));
}

}  // namespace

std::string run_replay(const BridgeConfig &config_in, const std::string &in_path, const std::string &out_path,
                       ReplayReport *report, const volatile std::sig_atomic_t *stop, const ReplayFrames &frames,
                       const ReplayProgress &progress) {
    *report = ReplayReport();
    BridgeConfig config = config_in;
    const double status_period_s = config.status_period_s;
    const int64_t lidar_wait_us = static_cast<int64_t>(config.lidar_wait_ms) * 1000;
    config.status_period_s = 0;  // driven on the log's clock below
    config.lidar_wait_ms = 0;    // the look-ahead replaces the wait, deterministically

    EventLogReader in;
    if (!in.open(in_path)) return "cannot read the log " + in.error();
    EventLogWriter writer;
    Output out;
    out.flow_channel = config.flow_channel;
    out.ego_channel = config.ego_channel;
    out.quality_channel = config.quality_channel;
    out.log = &writer;
    if (!writer.open(out_path)) return "cannot write the log " + writer.error();
    lcm_t *lcm = lcm_create("memq://");
    if (!lcm) return "cannot create an in-process LCM (memq://)";
    std::string error;
    {
        std::unique_ptr<Bridge> bridge = Bridge::create(config, lcm, &error);
        lcm_subscription_t *subs[4] = {nullptr, nullptr, nullptr, nullptr};
        if (bridge) {
            subs[0] = lcm_subscribe(lcm, config.flow_channel.c_str(), write_output, &out);
            subs[1] = lcm_subscribe(lcm, config.status_channel.c_str(), write_output, &out);
            subs[2] = lcm_subscribe(lcm, config.ego_channel.c_str(), write_output, &out);
            subs[3] = lcm_subscribe(lcm, config.quality_channel.c_str(), write_output, &out);
            if (!subs[0] || !subs[1] || !subs[2] || !subs[3]) error = "cannot subscribe to the output channels";
        }
        auto handled = [&] {
            const Counters c = bridge->counters();
            return c.stereo_received + c.warm_up_received + c.lidar_received + c.calibration_received;
        };
        bool interrupted = false;
        // Until the bridge has taken `target` input messages, its worker is idle and every
        // output it published is in the log. False (error or `interrupted` set) when an output
        // could not be written (it never will be: waiting for it would never end), LCM failed,
        // or `stop` was set.
        auto settle = [&](int64_t target) {
            for (;;) {
                if (bridge->run_once(10) != 0) {
                    error = "LCM receive failed";
                    return false;
                }
                if (out.failures) {
                    error = "cannot write " + out_path + ": " + writer.error();
                    return false;
                }
                if (stop && *stop) {
                    interrupted = true;
                    return false;
                }
                const Counters c = bridge->counters();
                if (handled() >= target && bridge->idle() && out.flows == c.results_published &&
                    out.status == c.status_published)
                    return true;
            }
        };
        auto feed = [&](const LogEvent &e) {
            const int64_t target = handled() + 1;
            if (lcm_publish(lcm, e.channel.c_str(), e.data.data(), static_cast<unsigned>(e.data.size())) != 0) {
                error = printf_string("handing event %" PRId64 " to the bridge failed", e.event_number);
                return false;
            }
            return settle(target);
        };
        LogReader reader(&in, config);
        double next_status = -1;
        int64_t last_utime = 0;
        int64_t stereo_index = -1;  // of the stereo event in hand, in log order
        while (error.empty() && !interrupted) {
            LogReader::Pending *p = reader.peek(0);
            if (!p) break;
            if (stop && *stop) {
                interrupted = true;
                break;
            }
            if (p->event->channel == config.stereo_channel && stereo_index + 1 > frames.last) {
                report->stopped_after_range = true;
                break;
            }
            EventPtr event = std::move(p->event);
            const bool fed_early = p->fed;
            reader.pop();
            ++report->events;
            const std::string &channel = event->channel;
            // A log clock that jumps by more than a day (a bad timestamp, a clock reset) is
            // worth a line: results and status are stamped with it.
            if (report->events > 1 && std::fabs(static_cast<double>(event->utime) - static_cast<double>(last_utime)) >
                                          kClockJumpUs) {
                if (++report->clock_jumps <= kMaxNotesPerKind)
                    report->notes.push_back(printf_string(
                        "log time jumps by %+.6g s at log event %" PRId64 " on %s (offset %" PRId64 ")%s",
                        (static_cast<double>(event->utime) - static_cast<double>(last_utime)) / 1e6,
                        event->event_number, channel.c_str(), event->offset,
                        report->clock_jumps == kMaxNotesPerKind ? "; further jumps only counted" : ""));
            }
            last_utime = event->utime;
            out.now = std::max(out.now, event->utime);
            if (channel == config.lidar_channel) {
                ++report->lidar_events;
                if (!fed_early) feed(*event);
            } else if (channel == config.calibration_channel) {
                ++report->calibration_events;
                feed(*event);
            } else if (channel == config.stereo_channel && ++stereo_index < frames.first - frames.warm_up) {
                ++report->stereo_before_range;  // its LiDAR is handed over in log order
            } else if (channel == config.stereo_channel) {
                // A warm-up frame goes the range's way (LiDAR look-ahead included) so that the
                // stream reaches the range as the whole log's replay would have it.
                const bool warm_up = stereo_index < frames.first;
                report->stereo_before_range += warm_up;
                report->stereo_warm_up += warm_up;
                report->stereo_events += !warm_up;
                // Sweeps logged shortly after the frame reach the live bridge while the frame
                // waits for them; hand them over first. The wait is bounded as the live one is:
                // by log time (a frame stamped ahead of the log's clock waits from the log time
                // of the event after it, not until its own stamp comes round) and by the bytes
                // and events read ahead. A frame whose look-ahead hit a bound is counted.
                int64_t window = event->utime;
                const char *cut = nullptr;
                size_t ahead_bytes = 0;
                for (size_t i = 0; error.empty(); ++i) {
                    LogReader::Pending *q = reader.peek(i);
                    if (!q) break;
                    if (i == 0 && later_than(event->utime, q->event->utime, lidar_wait_us)) {
                        window = q->event->utime;
                        cut = "the frame's log time is ahead of the events after it";
                    }
                    if (later_than(q->event->utime, window, lidar_wait_us)) break;
                    ahead_bytes += q->event->data.size() + q->event->channel.size();
                    if (i >= kLookaheadEvents || ahead_bytes > kLookaheadBytes) {
                        cut = "the look-ahead reached its bound of events or bytes";
                        break;
                    }
                    if (!q->fed && config.lidar_channel == q->event->channel) {
                        if (!feed(*q->event)) break;
                        q->fed = true;
                    }
                }
                report->lookahead_peak_bytes = std::max(report->lookahead_peak_bytes, static_cast<int64_t>(ahead_bytes));
                if (cut && ++report->lookahead_cut <= kMaxNotesPerKind)
                    report->notes.push_back(printf_string(
                        "stereo log event %" PRId64 " (log time %" PRId64 "): LiDAR look-ahead stopped, %s%s",
                        event->event_number, event->utime, cut,
                        report->lookahead_cut == kMaxNotesPerKind ? "; further such frames only counted" : ""));
                if (!error.empty() || interrupted) {
                    report->stereo_not_replayed += interrupted && !warm_up;
                    break;
                }
                bridge->set_warm_up(warm_up);
                const Counters before = bridge->counters();
                if (!feed(*event)) break;
                if (!warm_up) {  // a warm-up frame's fate is not the range's
                    note_losses(before, bridge->counters(), *event, &report->lost);
                    // The event ends after its 28-byte header (sync, number, time, two lengths), channel and data.
                    if (progress)
                        progress(report->stereo_events,
                                 event->offset + 28 + static_cast<int64_t>(event->channel.size() + event->data.size()));
                }
            } else {
                ++report->other_events;
            }
            if (status_period_s > 0 && error.empty()) {
                // Computed, not counted up period by period: one event stamped years ahead
                // (or at INT64_MAX) costs one status, not hours of loop.
                const double period = 1e6 * status_period_s, now = static_cast<double>(out.now);
                if (next_status < 0) next_status = now + period;
                if (now >= next_status) {
                    bridge->publish_status_now();
                    next_status += period * (std::floor((now - next_status) / period) + 1);
                    if (!(next_status > now)) next_status = now + period;  // rounding at 2^63
                    settle(handled());
                }
            }
        }
        report->stereo_in_log = stereo_index + 1;
        // A range past the log's end: the source shrank (or the caller miscounted); either way
        // the range's missing frames are lost, and a caller must hear of it.
        if (error.empty() && !interrupted && frames.last != INT64_MAX && !report->stopped_after_range && stereo_index < frames.last)
            report->lost.push_back(printf_string(
                "frames %" PRId64 ":%" PRId64 ": the log has only %" PRId64 " stereo frame(s), %s", frames.first,
                frames.last, stereo_index + 1,
                stereo_index < frames.first ? "none of the range"
                                            : printf_string("frames %" PRId64 "..%" PRId64 " missing", stereo_index + 1,
                                                            frames.last).c_str()));
        // Interrupted: the stereo frames not handed over, counted without reading their data.
        if (interrupted)
            report->stereo_not_replayed +=
                reader.count_rest(config.stereo_channel, monotonic_seconds() + 0.3, &report->not_replayed_counted);
        if (bridge) {
            bridge->stop();  // publishes what is left and the final status
            // run_once() is done after stop(); deliver the memq queue to the writers directly.
            for (int i = 0; i < 100; ++i) {
                const Counters c = bridge->counters();
                if (out.flows == c.results_published && out.status == c.status_published) break;
                lcm_handle_timeout(lcm, 10);
            }
            report->counters = bridge->counters();
            if (report->counters.dropped_shutdown)
                report->lost.push_back(printf_string("%" PRId64 " stereo frame(s) still queued when the replay stopped",
                                                     report->counters.dropped_shutdown));
        }
        report->interrupted = interrupted;
        for (lcm_subscription_t *s : subs)
            if (s) lcm_unsubscribe(lcm, s);
    }
    lcm_destroy(lcm);
    for (const EventLogReader::Problem &p : in.problems()) report->lost.push_back("log: " + p.text);
    if (!in.torn_tail().empty()) report->notes.push_back("log: " + in.torn_tail());
    if (report->lookahead_cut > kMaxNotesPerKind)
        report->notes.push_back(printf_string("LiDAR look-ahead stopped at a bound for %" PRId64 " frames in all",
                                              report->lookahead_cut));
    if (report->clock_jumps > kMaxNotesPerKind)
        report->notes.push_back(printf_string("log time jumps by more than a day %" PRId64 " times in all",
                                              report->clock_jumps));
    if (!writer.close() && error.empty()) error = "writing " + out_path + " failed: " + writer.error();
    report->flows_written = out.flows;
    report->status_written = out.status;
    if (error.empty() && out.failures) error = printf_string("%" PRId64 " events could not be written to %s", out.failures, out_path.c_str());
    if (error.empty() && out.flows != report->counters.results_published)
        error = printf_string("%" PRId64 " results published, %" PRId64 " written", report->counters.results_published, out.flows);
    if (error.empty() && out.egos != out.flows)
        error = printf_string("%" PRId64 " results written with %" PRId64 " ego-motions", out.flows, out.egos);
    if (error.empty() && out.qualities != out.flows)
        error = printf_string("%" PRId64 " results written with %" PRId64 " input qualities", out.flows, out.qualities);
    return error;
}

}  // namespace lidarflow::bridge
