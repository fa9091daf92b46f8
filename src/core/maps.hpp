// SPDX-License-Identifier: MIT
#pragma once
// Dense per-pixel maps in the left image at t0 (the reference frame), as the stages exchange
// them. Invalid disparities are negative (kInvalidDisparity), as in the KITTI devkit; a valid
// disparity is >= 0. Flow carries an explicit validity mask.
#include <algorithm>

#include <opencv2/core.hpp>

namespace lidarflow {

constexpr float kInvalidDisparity = -1.0f;

inline bool disparity_valid(float d) { return d >= 0.0f; }

// CV_32F disparity map, invalid pixels < 0.
using DisparityMap = cv::Mat1f;

// A rows x cols matrix with every element `value`, filled by setTo: OpenCV's fill constructors
// and operator=(Scalar) copy a non-zero value through a generic loop about ten times slower.
template <class T>
cv::Mat_<T> filled(int rows, int cols, const T &value) {
    cv::Mat_<T> m(rows, cols);
    m.setTo(cv::Scalar(value));
    return m;
}

template <class T>
cv::Mat_<T> filled(cv::Size size, const T &value) {
    return filled(size.height, size.width, value);
}

struct FlowField {
    cv::Mat1f u, v;   // displacement [px] from I_l^0 to I_l^1
    cv::Mat1b valid;  // 1 where (u, v) is defined, else 0

    static FlowField zeros(int width, int height) {
        return {cv::Mat1f::zeros(height, width), cv::Mat1f::zeros(height, width),
                cv::Mat1b::zeros(height, width)};
    }
    int width() const { return u.cols; }
    int height() const { return u.rows; }
};

// Scene flow SF(p) = (u, v, d0, d1) per pixel of I_l^0 (paper Eq. 1). d1 is the disparity at
// t1 of the point seen at p, i.e. already warped into the t0 reference frame (as KITTI's
// disp_1). One validity mask for the whole 4-vector: stages produce or drop whole matches.
struct SceneFlowField {
    cv::Mat1f u, v, d0, d1;
    cv::Mat1b valid;       // 1 where the 4-vector is defined
    cv::Mat1f confidence;  // larger is better; 0 where undefined

    static SceneFlowField zeros(int width, int height) {
        return {cv::Mat1f::zeros(height, width), cv::Mat1f::zeros(height, width),
                cv::Mat1f::zeros(height, width), cv::Mat1f::zeros(height, width),
                cv::Mat1b::zeros(height, width), cv::Mat1f::zeros(height, width)};
    }
    // Planes of the right size with undefined values, for a producer that writes every pixel
    // of every plane (skips a zero-fill pass over ~11 MB per KITTI field).
    static SceneFlowField uninitialized(int width, int height) {
        return {cv::Mat1f(height, width), cv::Mat1f(height, width), cv::Mat1f(height, width),
                cv::Mat1f(height, width), cv::Mat1b(height, width), cv::Mat1f(height, width)};
    }
    // Row y of every plane set to 0 (no match). With uninitialized(), a stage that visits every
    // row clears and fills it in one parallel pass instead of zeroing each plane on one thread.
    void clear_row(int y) {
        for (cv::Mat1f *m : {&u, &v, &d0, &d1, &confidence})
            std::fill(m->ptr<float>(y), m->ptr<float>(y) + m->cols, 0.0f);
        std::fill(valid.ptr<uchar>(y), valid.ptr<uchar>(y) + valid.cols, uchar{0});
    }
    int width() const { return u.cols; }
    int height() const { return u.rows; }
};

}  // namespace lidarflow
