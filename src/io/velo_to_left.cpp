// SPDX-License-Identifier: MIT
#include "io/velo_to_left.hpp"

#include <cmath>

#include "core/error.hpp"

namespace lidarflow::io {

cv::Matx44d velo_to_left_rect(const CamToCamCalib &calib, const cv::Matx44d &velo_to_cam) {
    bool finite = true;
    for (double v : calib.P_rect_02.val) finite = finite && std::isfinite(v);
    for (double v : calib.R_rect_00.val) finite = finite && std::isfinite(v);
    for (double v : velo_to_cam.val) finite = finite && std::isfinite(v);
    require(finite, ErrorCode::InvalidArgument, "velo_to_left_rect: non-finite calibration");
    const cv::Matx34d &P = calib.P_rect_02;
    require(P(0, 0) > 0 && P(1, 1) > 0 && P(1, 0) == 0 && P(2, 0) == 0 && P(2, 1) == 0 && P(2, 2) == 1,
            ErrorCode::InvalidArgument, "velo_to_left_rect: P_rect_02 is not a rectified pinhole K [I | t]");
    // K^-1 p of the upper-triangular K = [fx s cx; 0 fy cy; 0 0 1], by back substitution.
    const double tz = P(2, 3);
    const double ty = (P(1, 3) - P(1, 2) * tz) / P(1, 1);
    const double tx = (P(0, 3) - P(0, 1) * ty - P(0, 2) * tz) / P(0, 0);
    cv::Matx44d offset = cv::Matx44d::eye(), rect = cv::Matx44d::eye();
    offset(0, 3) = tx;
    offset(1, 3) = ty;
    offset(2, 3) = tz;
    for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) rect(r, k) = calib.R_rect_00(r, k);
    return offset * rect * velo_to_cam;
}

}  // namespace lidarflow::io
