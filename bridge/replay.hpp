// SPDX-License-Identifier: MIT
#pragma once
// Offline replay: an LCM log in, a result log out, at the estimator's pace.
//
// The log is read by EventLogReader (log_reader.hpp), which checks every header against the
// file and reads the same events as lidarflow_lcm's LogReader; corruption is reported in
// ReplayReport::lost, never silently ended on.
//
// The log's input events are handed one at a time to an ordinary Bridge over an in-process
// memq:// LCM, and the next one only once the bridge has handled it, the worker is idle and its
// outputs are written. So no frame can go stale, and every decision (pairing, calibration in
// force, order checks, drops for bad input) is the live bridge's own code. Outputs (scene_flow_t
// and status_t) go into a new log with the input log's clock: a result gets the log time of the
// stereo event that completed its pair, so lcm-logplayer plays results in step with the inputs.
#include <cstdint>
#include <csignal>
#include <functional>
#include <string>
#include <vector>

#include "bridge_core.hpp"
#include "log_reader.hpp"

namespace lidarflow::bridge {

struct ReplayReport {
    int64_t events = 0;         // events read from the input log
    int64_t stereo_events = 0, lidar_events = 0, calibration_events = 0;
    int64_t other_events = 0;   // on channels the bridge does not take (left out)
    int64_t flows_written = 0, status_written = 0;
    bool interrupted = false;         // `stop` was set
    int64_t stereo_not_replayed = 0;  // left when interrupted
    bool not_replayed_counted = true; // false: the count stopped short (at least that many)
    int64_t lookahead_cut = 0;        // stereo frames whose LiDAR look-ahead stopped at a bound (notes)
    int64_t lookahead_peak_bytes = 0; // the most data read ahead for one frame
    int64_t clock_jumps = 0;          // log time jumping by more than a day between events (notes)
    int64_t stereo_before_range = 0;  // stereo frames before ReplayFrames::first (warm-up ones included)
    int64_t stereo_warm_up = 0;       // of those, handed over as warm-up (ReplayFrames::warm_up)
    bool stopped_after_range = false; // a stereo frame after ReplayFrames::last ended the replay
    int64_t stereo_in_log = 0;        // stereo frames read (all of the log's unless stopped after the range)
    // One line per stereo frame that did not reach the estimator, frames missing from the log
    // (gaps in frame_number), and places where the log was corrupt (bytes skipped to the next
    // sync word, reading stopped: frames there are unaccounted for); empty when every frame was
    // processed.
    std::vector<std::string> lost;
    // Things worth telling that cost no frame (a torn tail: the last write cut short).
    std::vector<std::string> notes;
    Counters counters;          // the bridge's final counters
};

// A range of stereo frames, numbered 0.. in log order (every event on the stereo channel), both
// ends included: only the pairs of two frames inside it are published. Calibration and LiDAR
// events before the range are still handed over; reading ends at the first stereo frame after
// `last`. The estimator's stream carries priors from pair to pair, so the range's stream starts
// `warm_up` stereo frames before `first` (as far as the log has them): those frames go to the
// bridge in warm-up (Bridge::set_warm_up), their pairs computed and not published. A range
// whose warm-up reaches the log's first frame gets the whole log's results.
struct ReplayFrames {
    int64_t first = 0;
    int64_t last = INT64_MAX;
    int64_t warm_up = 0;
};

// Replays `in_path` into `out_path` (created or truncated) through a bridge configured by
// `config` (channels, calibration, estimator options, ...; its lcm URL is irrelevant).
// status_period_s counts log time here. A LiDAR sweep logged up to config.lidar_wait_ms after
// a stereo frame is handed over before that frame (as the live bridge would wait for it); the
// look-ahead is bounded in log time from the event after the frame, in events and in bytes.
// `stop` (optional) is polled between events and while waiting for the bridge, e.g. set by
// SIGINT. `frames` restricts the replay to a range of stereo frames. Returns "" when the replay
// ran to the end or was interrupted (frames may still be
// lost: see report->lost, report->interrupted), else the reason it could not: a log that cannot
// be read or an output that cannot be written (the first failed write ends the replay).
// `progress` (optional) is called after each stereo frame handed to the bridge with the stereo
// frames so far and the bytes of the input log read up to the end of that frame's event.
using ReplayProgress = std::function<void(int64_t stereo_frames, int64_t bytes_read)>;
std::string run_replay(const BridgeConfig &config, const std::string &in_path, const std::string &out_path,
                       ReplayReport *report, const volatile std::sig_atomic_t *stop = nullptr,
                       const ReplayFrames &frames = ReplayFrames(), const ReplayProgress &progress = {});

}  // namespace lidarflow::bridge
