// SPDX-License-Identifier: MIT
#pragma once
// Hand-built scene-flow fields for the consistency suites (test_consistency_*.cpp).
// Include it last, after the OpenCV / project headers.
#include <initializer_list>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "core/lidar.hpp"
#include "core/maps.hpp"

// cmocka.h (1.1.x) has no extern "C" of its own and defines a fail() macro that breaks <ios>:
// wrap it here, after every C++ header (test_support.hpp's own include is then a no-op).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

namespace lidarflow::test {

// Every pixel valid with the same 4-vector and confidence 1.
inline SceneFlowField constant_field(int w, int h, float u, float v, float d0, float d1) {
    SceneFlowField f = SceneFlowField::zeros(w, h);
    f.u.setTo(u);
    f.v.setTo(v);
    f.d0.setTo(d0);
    f.d1.setTo(d1);
    f.valid.setTo(1);
    f.confidence.setTo(1.0f);
    return f;
}

// The backward field that makes constant_field(u, v, d0, d1) round-trip exactly.
inline SceneFlowField matching_backward(int w, int h, float u, float v, float d0, float d1) {
    return constant_field(w, h, -u, -v, d1, d0);
}

// A copy that shares no pixel data with f (SceneFlowField's copy shares cv::Mat buffers).
inline SceneFlowField deep_copy(const SceneFlowField &f) {
    return {f.u.clone(), f.v.clone(), f.d0.clone(), f.d1.clone(), f.valid.clone(), f.confidence.clone()};
}

inline void set_match(SceneFlowField &f, int x, int y, float u, float v, float d0, float d1) {
    f.u(y, x) = u;
    f.v(y, x) = v;
    f.d0(y, x) = d0;
    f.d1(y, x) = d1;
    f.valid(y, x) = 1;
}

inline SparseLidar lidar_at(int w, int h, std::initializer_list<LidarPoint> pts) {
    SparseLidar l;
    l.width = w;
    l.height = h;
    l.points = pts;
    return l;
}

}  // namespace lidarflow::test
