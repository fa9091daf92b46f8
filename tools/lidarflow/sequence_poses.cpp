// SPDX-License-Identifier: MIT
#include "sequence_poses.hpp"

#include "result_files.hpp"

namespace lidarflow::cli {

long write_sequence_poses(const std::string &path, long first, const std::map<long, cv::Matx34d> &motions,
                          const std::vector<double> &stamps, io::PoseFormat format) {
    std::vector<cv::Matx34d> poses = {cv::Matx34d::eye()};
    std::vector<long> frames = {first};
    for (auto it = motions.find(first); it != motions.end(); it = motions.find(frames.back())) {
        poses.push_back(io::compose_pose(poses.back(), it->second));
        frames.push_back(frames.back() + 1);
    }
    std::vector<double> times;
    for (long k : frames)
        times.push_back(static_cast<size_t>(frames.back()) < stamps.size() ? stamps[static_cast<size_t>(k)]
                                                                           : static_cast<double>(k) / 10);
    write_text_durably(path, io::poses_text(poses, times, format));
    return frames.back();
}

}  // namespace lidarflow::cli
