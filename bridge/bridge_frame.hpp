// SPDX-License-Identifier: MIT
#pragma once
// A stereo frame on its way from the LCM thread to the worker (private to the bridge).
#include "bridge_core.hpp"

namespace lidarflow::bridge {

struct Bridge::Frame {
    StereoMessage stereo;
    // --shard: the frame's index in the stream, and whether it only serves as the t0 of this
    // shard's next pair (its own pair, with the frame before, belongs to another shard).
    int64_t index = 0;
    bool t0_only = false;
    bool warm_up = false;  // Bridge::set_warm_up(): feeds the stream only
    // Adds the frame to a Counters count, unless it is a warm-up frame: its fate is not the
    // replayed part's, so it is counted nowhere.
    void count_in(int64_t &counter) const { counter += warm_up ? 0 : 1; }
    lf_calibration_t calibration{};
    double received_seconds = 0;
};
}  // namespace lidarflow::bridge
