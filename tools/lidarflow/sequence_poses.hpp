// SPDX-License-Identifier: MIT
#pragma once
// The camera trajectory `lidarflow sequence` writes: frame `first` is the origin, each next
// frame's pose the previous one composed with the pair's ego-motion (io/poses.hpp).
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "io/poses.hpp"

namespace lidarflow::cli {

// Writes the poses of frames first, first + 1, ... as long as `motions` (pair t0 -> ego-motion
// [R | t], points of frame t0's camera -> frame t0 + 1's) has the next pair, to `path` (written
// under a temporary name, synced, renamed). TUM times are `stamps` (seconds, index = frame) when
// they cover the frames, else the frame numbers / 10 (KITTI raw's 10 Hz). Returns the last frame
// written. Throws Error(Io) when the file cannot be written.
long write_sequence_poses(const std::string &path, long first, const std::map<long, cv::Matx34d> &motions,
                          const std::vector<double> &stamps, io::PoseFormat format);

}  // namespace lidarflow::cli
