// SPDX-License-Identifier: MIT
#include "pipeline/confidence.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace lidarflow::pipeline {

void add_measured_support(SceneFlowField &dense, const SceneFlowField &measured, int radius, float tolerance,
                          float weight, int threads) {
    if (measured.u.empty() || measured.u.size() != dense.u.size() || radius < 0 || !(weight > 0.0f)) return;
    cv::Mat1f agree(dense.u.size(), 0.0f);
    const int T = std::max(1, threads);
#pragma omp parallel for schedule(static) num_threads(T)
    for (int y = 0; y < agree.rows; ++y)
        for (int x = 0; x < agree.cols; ++x)
            if (measured.valid(y, x) && std::fabs(measured.u(y, x) - dense.u(y, x)) <= tolerance &&
                std::fabs(measured.v(y, x) - dense.v(y, x)) <= tolerance &&
                std::fabs(measured.d0(y, x) - dense.d0(y, x)) <= tolerance)
                agree(y, x) = 1.0f;
    cv::Mat1f share;
    cv::boxFilter(agree, share, CV_32F, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1), true,
                  cv::BORDER_REPLICATE);
    const float norm = 1.0f / (1.0f + weight);
#pragma omp parallel for schedule(static) num_threads(T)
    for (int y = 0; y < agree.rows; ++y)
        for (int x = 0; x < agree.cols; ++x)
            if (dense.valid(y, x)) dense.confidence(y, x) = (dense.confidence(y, x) + weight * share(y, x)) * norm;
}

}  // namespace lidarflow::pipeline
