// SPDX-License-Identifier: MIT
#pragma once
// Camera trajectories as text: the KITTI odometry format (one line per frame, the 3x4 pose
// [R | t] row-major, 12 numbers, mapping the frame's camera coordinates to the first frame's) and
// the TUM RGB-D format ("time tx ty tz qx qy qz qw", the same pose as a unit quaternion).
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::io {

enum class PoseFormat { Kitti, Tum };

// "kitti" or "tum"; Error(InvalidArgument) for another name.
PoseFormat parse_pose_format(const std::string &name);

// The pose of a camera that moved by `motion` after `pose`: `motion` maps points of the earlier
// camera to the later one (P' = R P + t, as the ego-motion of a pair), so the later camera's pose
// is pose * motion^-1.
cv::Matx34d compose_pose(const cv::Matx34d &pose, const cv::Matx34d &motion);

// The poses as text in `format`; `times` (seconds, one per pose) for TUM.
std::string poses_text(const std::vector<cv::Matx34d> &poses, const std::vector<double> &times, PoseFormat format);

// Reads a KITTI-format file (at most 64 MiB, a regular file). Error: Io when unreadable, Format
// for a line of other than 12 finite numbers.
std::vector<cv::Matx34d> read_kitti_poses(const std::string &path);

}  // namespace lidarflow::io
