// SPDX-License-Identifier: MIT
#pragma once
// The estimator's rigid background motion as a matrix, for `run`'s report and `sequence`'s poses.
#include <opencv2/core.hpp>

#include "motion/ego_motion.hpp"

namespace lidarflow::cli {

// The rigid background motion as the C ABI's T (X1 = T X0); identity where there is none.
inline cv::Matx44d ego_matrix(const motion::EgoMotion &e) {
    cv::Matx44d T = cv::Matx44d::eye();
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) T(i, j) = e.R[3 * i + j];
        T(i, 3) = e.t[i];
    }
    return T;
}

}  // namespace lidarflow::cli
