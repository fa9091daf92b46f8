// SPDX-License-Identifier: MIT
// Test tool for the LCM bridge, on LCM event logs (as lcm-logger or a file:// URL writes them).
//   log_check verify LOG [--option K=V]... [--min-results N]
//       LOG holds the inputs (player) and the bridge's outputs: every scene_flow_t must equal
//       the C ABI's result for the inputs it names; the last status_t must account for every
//       stereo message (received = processed + dropped, nothing queued) and have received all
//       stereo messages in the log.
//   log_check verify OUT.log --inputs IN.log [...]
//       The same for a log of outputs only (lidarflow-lcm-bridge --replay IN.log --out OUT.log):
//       the inputs come from IN.log.
//   Input options (verify): --stereo-channel / --lidar-channel NAME (default LIDARFLOW_STEREO /
//       LIDARFLOW_LIDAR; bot_core.images_t / pointcloud_t are taken too, read with lcm-gen's
//       decoder), --calib FILE (a fixed KITTI calib_cam_to_cam.txt instead of LIDARFLOW_CALIB),
//       --lidar-to-camera "16 numbers" (for pointcloud_t, as the bridge's option).
//   Sharded runs (--shard K/N, all shards on one status channel): the last status of every
//       shard must account for every stereo frame (received = processed + dropped + skipped for
//       other shards), no two results may name the same pair, and the results together must
//       match the shards' counts. --expect-pairs P: exactly P results and no frame dropped by
//       any shard. --check-every M: compare only every M-th result with the C ABI (time).
//       --dead-shard K: shard K was killed mid-stream; its last status is not final and is left
//       out of the accounting; every live shard must have taken it for dead, and the pairs
//       published (by anyone, K included) plus the pairs the live shards counted as lost
//       (pairs_lost_dead_shard) must be exactly --expect-pairs.
//   log_check throughput LOG [--stereo-channel NAME]
//       Results per second of a recorded live run: from the first stereo frame's to the last
//       result's arrival at the logger.
//   log_check compare A.log B.log [--bytes]
//       The results of two runs of the same frames (times may differ: paired by order) must be
//       equal value by value: same pair length t1 - t0, LiDAR flags, planes and valid pixels.
//       E.g. one scan sent as LiDAR-frame points and once as projected disparities. --bytes:
//       also the same t0 and t1 and the same bytes of the u, v, d0, d1 and valid planes (a part
//       of a log replayed against the whole log's replay).
//   log_check edit IN.log OUT.log --drop CHANNEL:N [--drop ...]
//       Copies IN.log without the N-th (from 0) event on CHANNEL: logs with missing frames.
//   log_check replay LOG [--option K=V]... [--min-results N] [--encoding E] [--step N]
//       Replays LOG's input messages into an in-process bridge over memq://, one frame at a
//       time (waiting for the bridge), and checks every result as above; no frame may drop.
#include <lcm/eventlog.h>
#include <lcm/lcm.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "bridge_core.hpp"
#include "calib_file.hpp"
#include "flow_reference.hpp"
#include "lidarflow_status_t.h"

using namespace lidarflow::bridge;
using testing::Inputs;

namespace {

struct Event {
    int64_t timestamp;  // the logger's receive time [us]
    std::string channel;
    std::vector<uint8_t> data;
};

bool read_log(const std::string &path, std::vector<Event> &events) {
    lcm_eventlog_t *log = lcm_eventlog_create(path.c_str(), "r");
    if (!log) return false;
    while (lcm_eventlog_event_t *e = lcm_eventlog_read_next_event(log)) {
        const auto *d = static_cast<const uint8_t *>(e->data);
        events.push_back({e->timestamp, std::string(e->channel, e->channellen), std::vector<uint8_t>(d, d + e->datalen)});
        lcm_eventlog_free_event(e);
    }
    lcm_eventlog_destroy(log);
    return true;
}

struct InputSetup {
    std::string stereo_channel = "LIDARFLOW_STEREO", lidar_channel = "LIDARFLOW_LIDAR";
    bool fixed_calibration = false;
    lf_calibration_t calibration{};
    bool have_lidar_to_camera = false;
    double lidar_to_camera[16] = {};
    int check_every = 1;
};

// Checks every flow in `flows` against the inputs; calibration: the fixed one, else the last
// valid one in `events` before the flow's t1 frame (the player sends one per sequence).
int check_flows(const std::vector<Event> &events, const std::vector<std::vector<uint8_t>> &flows,
                const std::vector<std::pair<std::string, std::string>> &options, int min_results,
                const InputSetup &setup) {
    Inputs inputs;
    inputs.have_lidar_to_camera = setup.have_lidar_to_camera;
    std::copy(setup.lidar_to_camera, setup.lidar_to_camera + 16, inputs.lidar_to_camera);
    std::map<int64_t, lf_calibration_t> calibration_of;  // stereo utime -> calibration in force
    lf_calibration_t cal = setup.calibration;
    bool have_cal = setup.fixed_calibration;
    for (const Event &e : events) {
        int64_t utime = 0;
        if (e.channel == "LIDARFLOW_CALIB" && !setup.fixed_calibration) {
            int32_t w, h;
            have_cal |= decode_calibration(e.data.data(), e.data.size(), &cal, &w, &h).empty();
        } else if (e.channel == setup.stereo_channel) {
            StereoMessage m;
            const bool own = decode_stereo(e.data.data(), e.data.size(), m).empty();
            if (own) utime = m.msg().utime;
            if ((own || testing::bot_core_utime(e.data, &utime)) && have_cal) {
                inputs.stereo[utime] = e.data;
                calibration_of[utime] = cal;
            }
        } else if (e.channel == setup.lidar_channel) {
            LidarSweep s;
            if (decode_lidar(e.data.data(), e.data.size(), s).empty()) inputs.lidar[s.utime] = e.data;
            else if (testing::bot_core_utime(e.data, &utime)) inputs.lidar[utime] = e.data;
        }
    }
    int ok = 0, with_lidar = 0;
    for (size_t i = 0; i < flows.size(); i += static_cast<size_t>(setup.check_every)) {
        const auto &f = flows[i];
        DecodedFlow d;
        const std::string derr = decode_scene_flow(f.data(), f.size(), d);
        if (!derr.empty() || !calibration_of.count(d.header.utime)) {
            std::fprintf(stderr, "log_check: bad flow message: %s\n", derr.empty() ? "unknown frame" : derr.c_str());
            return 1;
        }
        const std::string err = testing::check_flow(options, calibration_of[d.header.utime], inputs, f);
        if (!err.empty()) {
            std::fprintf(stderr, "log_check: flow %lld -> %lld: %s\n", (long long)d.header.utime0,
                         (long long)d.header.utime, err.c_str());
            return 1;
        }
        ++ok;
        with_lidar += d.header.lidar_flags != 0;
    }
    std::printf("log_check: %d scene flow results equal the C ABI's (%d with LiDAR)\n", ok, with_lidar);
    if (ok < min_results) {
        std::fprintf(stderr, "log_check: expected at least %d results\n", min_results);
        return 1;
    }
    return 0;
}

// log_check compare: see the top of the file.
int compare_results(const std::string &path_a, const std::string &path_b, bool bytes) {
    std::vector<DecodedFlow> runs[2];
    std::vector<std::vector<uint8_t>> raw[2];
    for (int k = 0; k < 2; ++k) {
        std::vector<Event> events;
        if (!read_log(k ? path_b : path_a, events)) {
            std::fprintf(stderr, "log_check: cannot read %s\n", (k ? path_b : path_a).c_str());
            return 1;
        }
        for (const Event &e : events) {
            if (e.channel != "LIDARFLOW_FLOW") continue;
            DecodedFlow d;
            const std::string err = decode_scene_flow(e.data.data(), e.data.size(), d);
            if (!err.empty()) {
                std::fprintf(stderr, "log_check: bad flow message: %s\n", err.c_str());
                return 1;
            }
            runs[k].push_back(std::move(d));
            raw[k].push_back(e.data);
        }
    }
    if (runs[0].size() != runs[1].size() || runs[0].empty()) {
        std::fprintf(stderr, "log_check: compare: %zu and %zu results\n", runs[0].size(), runs[1].size());
        return 1;
    }
    int rc = 0;
    for (size_t i = 0; i < runs[0].size(); ++i) {
        const DecodedFlow &a = runs[0][i], &b = runs[1][i];
        const lidarflow_scene_flow_t &ha = a.header, &hb = b.header;
        if (ha.utime - ha.utime0 != hb.utime - hb.utime0 || ha.lidar_flags != hb.lidar_flags ||
            ha.width != hb.width || ha.height != hb.height || ha.last_stage != hb.last_stage) {
            std::fprintf(stderr, "log_check: compare: result %zu: different pairs (t1 - t0 %lld / %lld us, LiDAR flags "
                                 "%d / %d, planes %dx%d / %dx%d)\n",
                         i, (long long)(ha.utime - ha.utime0), (long long)(hb.utime - hb.utime0), ha.lidar_flags,
                         hb.lidar_flags, ha.width, ha.height, hb.width, hb.height);
            return 1;
        }
        if (bytes) {
            // The planes end the message (scene_flow_t.lcm): u, v, d0, d1, then valid.
            const size_t planes = 4 * static_cast<size_t>(ha.plane_size) + static_cast<size_t>(ha.valid_size);
            const std::vector<uint8_t> &ra = raw[0][i], &rb = raw[1][i];
            if (ha.utime != hb.utime || ha.utime0 != hb.utime0 || ha.encoding != hb.encoding || ha.step != hb.step ||
                ha.plane_size != hb.plane_size || !std::equal(ra.end() - static_cast<std::ptrdiff_t>(planes), ra.end(),
                                                              rb.end() - static_cast<std::ptrdiff_t>(planes))) {
                std::fprintf(stderr, "log_check: compare --bytes: result %zu (t0 %lld / %lld, t1 %lld / %lld): the plane "
                                     "bytes differ\n",
                             i, (long long)ha.utime0, (long long)hb.utime0, (long long)ha.utime, (long long)hb.utime);
                rc = 1;
            }
        }
        const std::vector<float> *pa[4] = {&a.u, &a.v, &a.d0, &a.d1}, *pb[4] = {&b.u, &b.v, &b.d0, &b.d1};
        size_t valid = 0, differ = 0;
        double max_diff = 0;
        for (size_t j = 0; j < a.valid.size(); ++j) {
            if (!a.valid[j] && !b.valid[j]) continue;
            ++valid;
            double d = a.valid[j] != b.valid[j] ? HUGE_VAL : 0;
            for (int k = 0; k < 4 && a.valid[j] && b.valid[j]; ++k)
                d = std::max(d, static_cast<double>(std::fabs((*pa[k])[j] - (*pb[k])[j])));
            if (d != HUGE_VAL) max_diff = std::max(max_diff, d);
            differ += d != 0;
        }
        const double fraction = valid ? static_cast<double>(differ) / static_cast<double>(valid) : 0;
        std::printf("log_check: compare: result %zu (LiDAR flags %d): %zu pixels valid in either, %zu differ (%.5f %%), "
                    "largest difference where both are valid %.4g px\n",
                    i, ha.lidar_flags, valid, differ, 100 * fraction, max_diff);
        if (differ != 0) rc = 1;
    }
    if (rc) std::fprintf(stderr, "log_check: compare: the results differ\n");
    return rc;
}

}  // namespace

int main(int argc, char **argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: log_check verify|replay LOG [--option K=V]... [--min-results N]\n");
        return 2;
    }
    const std::string mode = argv[1], path = argv[2];
    if (mode == "compare") {
        const bool bytes = argc == 5 && std::strcmp(argv[4], "--bytes") == 0;
        return argc != 4 && !bytes ? 2 : compare_results(path, argv[3], bytes);
    }
    if (mode == "edit") {
        if (argc < 4) return 2;
        std::map<std::string, std::vector<int>> drop;  // channel -> event indices
        for (int i = 4; i + 1 < argc; i += 2) {
            const std::string a = argv[i], v = argv[i + 1];
            const size_t colon = v.rfind(':');
            if (a != "--drop" || colon == std::string::npos) {
                std::fprintf(stderr, "log_check: bad argument %s %s\n", a.c_str(), v.c_str());
                return 2;
            }
            drop[v.substr(0, colon)].push_back(std::atoi(v.c_str() + colon + 1));
        }
        lcm_eventlog_t *in = lcm_eventlog_create(path.c_str(), "r");
        lcm_eventlog_t *out = lcm_eventlog_create(argv[3], "w");
        if (!in || !out) return 1;
        std::map<std::string, int> seen;
        int dropped = 0;
        while (lcm_eventlog_event_t *e = lcm_eventlog_read_next_event(in)) {
            const std::string channel(e->channel, e->channellen);
            const int index = seen[channel]++;
            const auto &d = drop[channel];
            if (std::find(d.begin(), d.end(), index) != d.end()) ++dropped;
            else if (lcm_eventlog_write_event(out, e) != 0) return 1;
            lcm_eventlog_free_event(e);
        }
        lcm_eventlog_destroy(in);
        lcm_eventlog_destroy(out);
        std::printf("log_check: %d event(s) left out\n", dropped);
        return 0;
    }
    std::string inputs_path;
    InputSetup setup;
    std::vector<std::pair<std::string, std::string>> options;
    int min_results = 1, step = 1, expect_pairs = -1, dead_shard = -1;
    FlowEncoding encoding = FlowEncoding::Int16;
    for (int i = 3; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--option" && v.find('=') != std::string::npos)
            options.emplace_back(v.substr(0, v.find('=')), v.substr(v.find('=') + 1));
        else if (a == "--inputs") inputs_path = v;
        else if (a == "--stereo-channel") setup.stereo_channel = v;
        else if (a == "--expect-pairs") expect_pairs = std::atoi(v.c_str());
        else if (a == "--dead-shard") dead_shard = std::atoi(v.c_str());
        else if (a == "--check-every") setup.check_every = std::max(1, std::atoi(v.c_str()));
        else if (a == "--lidar-channel") setup.lidar_channel = v;
        else if (a == "--calib") {
            const std::string err = read_calibration(v, &setup.calibration);
            if (!err.empty()) {
                std::fprintf(stderr, "log_check: %s\n", err.c_str());
                return 2;
            }
            setup.fixed_calibration = true;
        } else if (a == "--lidar-to-camera") {
            std::string text = v;
            std::replace(text.begin(), text.end(), ',', ' ');
            char *p = &text[0];
            int n = 0;
            for (char *end = nullptr; n < 16; ++n, p = end) {
                setup.lidar_to_camera[n] = std::strtod(p, &end);
                if (end == p) break;
            }
            if (n != 16) {
                std::fprintf(stderr, "log_check: --lidar-to-camera needs 16 numbers\n");
                return 2;
            }
            setup.have_lidar_to_camera = true;
        }
        else if (a == "--min-results") min_results = std::atoi(v.c_str());
        else if (a == "--step") step = std::atoi(v.c_str());
        else if (a == "--encoding" && parse_flow_encoding(v, &encoding)) {
        } else {
            std::fprintf(stderr, "log_check: bad argument %s %s\n", a.c_str(), v.c_str());
            return 2;
        }
    }
    std::vector<Event> events;
    if (!read_log(path, events)) {
        std::fprintf(stderr, "log_check: cannot read %s\n", path.c_str());
        return 1;
    }
    // Inputs from another log: they precede the outputs (only their order among themselves and
    // the outputs' among themselves matters below).
    if (!inputs_path.empty()) {
        std::vector<Event> inputs;
        if (!read_log(inputs_path, inputs)) {
            std::fprintf(stderr, "log_check: cannot read %s\n", inputs_path.c_str());
            return 1;
        }
        events.insert(events.begin(), inputs.begin(), inputs.end());
    }
    int64_t stereo_in_log = 0;
    for (const Event &e : events) stereo_in_log += e.channel == setup.stereo_channel;
    std::vector<std::vector<uint8_t>> flows;

    if (mode == "throughput") {
        int64_t first = -1, last = -1, results = 0, stereo = 0, last_stereo = -1;
        for (const Event &e : events) {
            if (e.channel == setup.stereo_channel) {
                if (first < 0) first = e.timestamp;
                last_stereo = e.timestamp;
                ++stereo;
            } else if (e.channel == "LIDARFLOW_FLOW") {
                last = e.timestamp;
                ++results;
            }
        }
        if (first < 0 || last <= first) {
            std::fprintf(stderr, "log_check: no stereo frames or no results after them\n");
            return 1;
        }
        const double s = 1e-6 * static_cast<double>(last - first),
                     stream = 1e-6 * static_cast<double>(last_stereo - first);
        std::printf("log_check: throughput: %lld results in %.2f s = %.2f results/s (stream: %lld frames in %.2f s, "
                    "%.2f frames/s)\n",
                    (long long)results, s, static_cast<double>(results) / s, (long long)stereo, stream,
                    stream > 0 ? static_cast<double>(stereo - 1) / stream : 0.0);
        return 0;
    }
    if (mode == "verify") {
        std::map<int32_t, StatusMessage> last_status;  // per shard
        std::map<std::pair<int64_t, int64_t>, int> pairs;  // (utime0, utime) -> results
        for (const Event &e : events) {
            if (e.channel == "LIDARFLOW_FLOW") {
                flows.push_back(e.data);
                DecodedFlow d;
                if (decode_scene_flow(e.data.data(), e.data.size(), d).empty())
                    ++pairs[{d.header.utime0, d.header.utime}];
            }
            StatusMessage status;
            if (e.channel == "LIDARFLOW_STATUS") {
                const std::string serr = decode_status(e.data.data(), e.data.size(), status);
                if (!serr.empty()) {
                    std::fprintf(stderr, "log_check: undecodable status message in %s: %s\n", path.c_str(), serr.c_str());
                    return 1;
                }
                last_status[status.fields.shard_index] = status;
            }
        }
        if (last_status.empty()) {
            std::fprintf(stderr, "log_check: no status message in %s\n", path.c_str());
            return 1;
        }
        int64_t results = 0, dropped_all = 0, lost_dead = 0;
        bool accounted = true;
        for (const auto &[shard, status] : last_status) {
            const lidarflow_status_t &s = status.fields;
            if (shard == dead_shard) continue;
            const int64_t dropped = s.dropped_stale + s.dropped_out_of_order + s.dropped_no_calibration +
                                    s.dropped_calibration_mismatch + s.dropped_malformed + s.dropped_estimator_error +
                                    s.dropped_shutdown + s.dropped_unpaired;
            std::printf("log_check: status of shard %d/%d: stereo received %lld (log has %lld), processed %lld, dropped "
                        "%lld (stale %lld), skipped for other shards %lld, results %lld, latency mean %.1f ms max %.1f "
                        "ms, estimator mean %.1f ms, queue %d, busy %d\n",
                        s.shard_index, s.shard_count, (long long)s.stereo_received, (long long)stereo_in_log,
                        (long long)s.stereo_processed, (long long)dropped, (long long)s.dropped_stale,
                        (long long)s.skipped_other_shard, (long long)s.results_published, s.latency_mean_ms,
                        s.latency_max_ms, s.compute_mean_ms, s.queue_depth, s.busy);
            if (dead_shard >= 0) {
                std::printf("log_check: shard %d takes %d shard(s) for dead and counted %lld of their pairs as lost\n",
                            s.shard_index, s.shards_dead, (long long)s.pairs_lost_dead_shard);
                accounted &= s.shards_dead == 1;
                lost_dead += s.pairs_lost_dead_shard;
            }
            accounted &= s.stereo_received == s.stereo_processed + dropped + s.skipped_other_shard &&
                         s.queue_depth == 0 && s.busy == 0 && s.stereo_received == stereo_in_log &&
                         s.shard_count == static_cast<int32_t>(last_status.size() + (dead_shard >= 0 &&
                                                                                    !last_status.count(dead_shard)));
            results += s.results_published;
            dropped_all += dropped;
        }
        // A dead shard's results are in the log but not in a final status of its own.
        accounted &= dead_shard >= 0 ? results <= static_cast<int64_t>(flows.size())
                                     : results == static_cast<int64_t>(flows.size());
        if (!accounted) {
            std::fprintf(stderr, "log_check: the status does not account for every stereo frame / result (or a shard "
                                 "is missing)\n");
            return 1;
        }
        for (const auto &[pair, n] : pairs)
            if (n != 1) {
                std::fprintf(stderr, "log_check: the pair %lld -> %lld was published %d times\n", (long long)pair.first,
                             (long long)pair.second, n);
                return 1;
            }
        if (expect_pairs >= 0 &&
            (static_cast<int64_t>(pairs.size()) + lost_dead != expect_pairs || dropped_all != 0)) {
            std::fprintf(stderr, "log_check: %zu distinct pairs published, %lld counted as lost with a dead shard, %lld "
                                 "frames dropped; expected %d pairs in all and no drop\n",
                         pairs.size(), (long long)lost_dead, (long long)dropped_all, expect_pairs);
            return 1;
        }
        if (dead_shard >= 0)
            std::printf("log_check: %zu pairs published + %lld lost with dead shard %d = %d\n", pairs.size(),
                        (long long)lost_dead, dead_shard, expect_pairs);
        return check_flows(events, flows, options, min_results, setup);
    }
    if (mode != "replay") {
        std::fprintf(stderr, "log_check: unknown mode %s\n", mode.c_str());
        return 2;
    }
    lcm_t *lcm = lcm_create("memq://");
    if (!lcm) return 1;
    BridgeConfig config;
    config.options = options;
    config.encoding = encoding;
    config.step = step;
    config.status_period_s = 0;
    config.lidar_wait_ms = 0;  // the log has each sweep before its frame
    std::string error;
    int rc = 0;
    {
        std::unique_ptr<Bridge> bridge = Bridge::create(config, lcm, &error);
        if (!bridge) {
            std::fprintf(stderr, "log_check: %s\n", error.c_str());
            lcm_destroy(lcm);
            return 1;
        }
        lcm_subscription_t *sub = lcm_subscribe(
            lcm, "LIDARFLOW_FLOW",
            [](const lcm_recv_buf_t *rbuf, const char *, void *user) {
                const auto *d = static_cast<const uint8_t *>(rbuf->data);
                static_cast<std::vector<std::vector<uint8_t>> *>(user)->emplace_back(d, d + rbuf->data_size);
            },
            &flows);
        for (const Event &e : events) {
            if (e.channel != "LIDARFLOW_STEREO" && e.channel != "LIDARFLOW_LIDAR" && e.channel != "LIDARFLOW_CALIB")
                continue;
            auto handled = [&] {
                const Counters c = bridge->counters();
                return c.stereo_received + c.lidar_received + c.calibration_received;
            };
            const int64_t target = handled() + 1;
            lcm_publish(lcm, e.channel.c_str(), e.data.data(), static_cast<unsigned>(e.data.size()));
            // Lock-step: the next message only once this one is fully handled and published.
            while (handled() < target || !bridge->idle()) bridge->run_once(10);
        }
        for (int i = 0; i < 5; ++i) bridge->run_once(1);
        bridge->stop();
        const Counters c = bridge->counters();
        std::printf("log_check: replayed %lld stereo frames: processed %lld, dropped %lld, results %lld\n",
                    (long long)c.stereo_received, (long long)c.stereo_processed, (long long)c.dropped(),
                    (long long)c.results_published);
        if (c.stereo_received != stereo_in_log || c.stereo_processed != stereo_in_log || c.dropped() != 0 ||
            c.results_published != static_cast<int64_t>(flows.size())) {
            std::fprintf(stderr, "log_check: the replay lost frames or results\n");
            rc = 1;
        }
        lcm_unsubscribe(lcm, sub);
    }
    lcm_destroy(lcm);
    return rc ? rc : check_flows(events, flows, options, min_results, setup);
}
