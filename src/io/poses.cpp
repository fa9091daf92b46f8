// SPDX-License-Identifier: MIT
#include "io/poses.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/error.hpp"
#include "io/read_file.hpp"

namespace lidarflow::io {

PoseFormat parse_pose_format(const std::string &name) {
    if (name == "kitti") return PoseFormat::Kitti;
    if (name == "tum") return PoseFormat::Tum;
    throw Error(ErrorCode::InvalidArgument, "pose format '" + name + "' is neither kitti nor tum");
}

cv::Matx34d compose_pose(const cv::Matx34d &pose, const cv::Matx34d &motion) {
    const cv::Matx33d R = pose.get_minor<3, 3>(0, 0), M = motion.get_minor<3, 3>(0, 0);
    const cv::Vec3d t(pose(0, 3), pose(1, 3), pose(2, 3)), m(motion(0, 3), motion(1, 3), motion(2, 3));
    // motion^-1 = [M^T | -M^T m].
    const cv::Matx33d Ro = R * M.t();
    const cv::Vec3d to = t - Ro * m;
    cv::Matx34d out;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) out(r, c) = Ro(r, c);
        out(r, 3) = to[r];
    }
    return out;
}

namespace {

// The unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method: the largest of the
// four candidate divisors keeps it accurate near 180 degrees).
cv::Vec4d quaternion(const cv::Matx34d &P) {
    const double tr = P(0, 0) + P(1, 1) + P(2, 2);
    double x, y, z, w;
    if (tr > 0) {
        const double s = 2 * std::sqrt(1 + tr);
        w = s / 4, x = (P(2, 1) - P(1, 2)) / s, y = (P(0, 2) - P(2, 0)) / s, z = (P(1, 0) - P(0, 1)) / s;
    } else if (P(0, 0) > P(1, 1) && P(0, 0) > P(2, 2)) {
        const double s = 2 * std::sqrt(1 + P(0, 0) - P(1, 1) - P(2, 2));
        w = (P(2, 1) - P(1, 2)) / s, x = s / 4, y = (P(0, 1) + P(1, 0)) / s, z = (P(0, 2) + P(2, 0)) / s;
    } else if (P(1, 1) > P(2, 2)) {
        const double s = 2 * std::sqrt(1 + P(1, 1) - P(0, 0) - P(2, 2));
        w = (P(0, 2) - P(2, 0)) / s, x = (P(0, 1) + P(1, 0)) / s, y = s / 4, z = (P(1, 2) + P(2, 1)) / s;
    } else {
        const double s = 2 * std::sqrt(1 + P(2, 2) - P(0, 0) - P(1, 1));
        w = (P(1, 0) - P(0, 1)) / s, x = (P(0, 2) + P(2, 0)) / s, y = (P(1, 2) + P(2, 1)) / s, z = s / 4;
    }
    return {x, y, z, w};
}

}  // namespace

std::string poses_text(const std::vector<cv::Matx34d> &poses, const std::vector<double> &times, PoseFormat format) {
    require(format == PoseFormat::Kitti || times.size() == poses.size(), ErrorCode::InvalidArgument,
            "poses_text: TUM needs one time per pose");
    std::string text;
    char buf[96];
    for (size_t i = 0; i < poses.size(); ++i) {
        const cv::Matx34d &P = poses[i];
        if (format == PoseFormat::Kitti) {
            for (int k = 0; k < 12; ++k) {
                std::snprintf(buf, sizeof buf, k ? " %.9e" : "%.9e", P.val[k]);
                text += buf;
            }
        } else {
            const cv::Vec4d q = quaternion(P);
            std::snprintf(buf, sizeof buf, "%.6f %.9f %.9f %.9f", times[i], P(0, 3), P(1, 3), P(2, 3));
            text += buf;
            std::snprintf(buf, sizeof buf, " %.9f %.9f %.9f %.9f", q[0], q[1], q[2], q[3]);
            text += buf;
        }
        text += '\n';
    }
    return text;
}

std::vector<cv::Matx34d> read_kitti_poses(const std::string &path) {
    std::istringstream in(read_file(path, kMaxTextFileBytes));
    std::vector<cv::Matx34d> poses;
    std::string line;
    for (int lineno = 1; std::getline(in, line); ++lineno) {
        std::istringstream fields(line);
        cv::Matx34d P;
        int n = 0;
        double v;
        while (n < 13 && fields >> v) {
            if (n < 12) P.val[n] = v;
            require(std::isfinite(v), ErrorCode::Format, path + ":" + std::to_string(lineno) + ": non-finite value");
            ++n;
        }
        require(n == 12 && fields.eof(), ErrorCode::Format,
                path + ":" + std::to_string(lineno) + ": expected 12 numbers (a 3x4 pose)");
        poses.push_back(P);
    }
    return poses;
}

}  // namespace lidarflow::io
