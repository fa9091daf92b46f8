// SPDX-License-Identifier: MIT
#include "matching/motion_prior.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/limits.hpp"
#include "core/maps.hpp"
#include "core/pixels.hpp"
#include "core/points3d.hpp"
#include "core/rounding.hpp"
#include "lidar/projection.hpp"

namespace lidarflow::matching {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// An object motion that moves the point's image by less than this is the fit's noise [px].
constexpr double kMinImageMotion = 1.0;

bool finite3(const cv::Vec3f &v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// Pixel of camera point p; false behind (or nearly at) the camera.
bool project(const StereoCamera &c, const double p[3], double &x, double &y) {
    if (!(p[2] > 1e-3)) return false;
    x = c.fx * p[0] / p[2] + c.cx;
    y = c.fy * p[1] / p[2] + c.cy;
    return std::isfinite(x) && std::isfinite(y);
}

void rigid(const double R[9], const double t[3], const double p[3], double out[3]) {
    for (int i = 0; i < 3; ++i) out[i] = R[3 * i] * p[0] + R[3 * i + 1] * p[1] + R[3 * i + 2] * p[2] + t[i];
}

// An object motion one frame step later at constant velocity: the same motion in the world,
// so in the camera frame turned by the step's rotation R.
cv::Vec3f next_step(const double R[9], const cv::Vec3f &o) {
    cv::Vec3f r;
    for (int i = 0; i < 3; ++i) r[i] = static_cast<float>(R[3 * i] * o[0] + R[3 * i + 1] * o[1] + R[3 * i + 2] * o[2]);
    return r;
}

// Empty pixels take a 3x3 neighbour's value: a point that comes closer covers more pixels at t1
// than it had at t0, and the splat leaves single-pixel gaps inside it.
cv::Mat3f close_gaps(const cv::Mat3f &m, int threads) {
    cv::Mat3f out = m.clone();
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x) {
            if (finite3(m(y, x))) continue;
            for (int dy = -1; dy <= 1 && !finite3(out(y, x)); ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int yy = y + dy, xx = x + dx;
                    if (yy < 0 || xx < 0 || yy >= m.rows || xx >= m.cols || !finite3(m(yy, xx))) continue;
                    out(y, x) = m(yy, xx);
                    break;
                }
        }
    return out;
}

// One more frame step at constant velocity: every point (disparity d at its pixel) moves by the
// background motion `ego` plus its object motion (none for the static ones, NaN in `objects`),
// and lands on its new pixel, the nearest point winning.
void advance_one_step(cv::Mat3f &objects, cv::Mat1f &d, const motion::EgoMotion &ego, const StereoCamera &c) {
    cv::Mat3f moved = filled(objects.size(), cv::Vec3f(kNaN, kNaN, kNaN));
    cv::Mat1f nearest(objects.size(), 0.0f);
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x) {
            if (!(d(y, x) > 0.0f)) continue;
            const bool mover = finite3(objects(y, x));
            const cv::Vec3f o = mover ? next_step(ego.R, objects(y, x)) : objects(y, x);
            double p[3], q[3], tx, ty;
            back_project(c, x, y, d(y, x), p);
            rigid(ego.R, ego.t, p, q);
            if (mover)
                for (int i = 0; i < 3; ++i) q[i] += o[i];
            if (!project(c, q, tx, ty)) continue;
            const int px = static_cast<int>(std::lround(tx)), py = static_cast<int>(std::lround(ty));
            const float nd = static_cast<float>(c.disparity_from_depth(q[2]));
            if (px < 0 || py < 0 || px >= d.cols || py >= d.rows || !(nd > nearest(py, px))) continue;
            nearest(py, px) = nd;
            moved(py, px) = mover ? o : cv::Vec3f(kNaN, kNaN, kNaN);
        }
    objects = moved;
    d = nearest;
}

}  // namespace

cv::Mat3f carry_object_motion(const SceneFlowField &f, const motion::EgoMotion &ego, const StereoCamera &camera,
                              int steps, int threads) {
    if (!ego.valid || !ego.calibrated || !camera.valid() || f.u.empty()) return {};
    const int w = f.width(), h = f.height();
    // Each point's landing pixel (y * w + x; -1: none) and object motion, in parallel; then the
    // landings in raster order, so that the nearest point wins and the first of equally near ones.
    cv::Mat1i lands(h, w);
    cv::Mat3f motions(h, w);
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            lands(y, x) = -1;
            if (!f.valid(y, x)) continue;
            const float u = f.u(y, x), v = f.v(y, x), d1 = f.d1(y, x);
            ScenePoint3 q;
            if (!triangulate_scene_flow(camera, x, y, u, v, f.d0(y, x), d1, &q)) continue;
            int tx, ty;
            if (!nearest_inside(x + u, y + v, w, h, tx, ty)) continue;
            double obj[3], p0[3] = {q.x, q.y, q.z}, bg[3], xb, yb;
            object_motion(q, ego.R, ego.t, obj);
            rigid(ego.R, ego.t, p0, bg);
            bool moved = !project(camera, bg, xb, yb);
            if (!moved) {  // sqrt, not hypot (a libm call per pixel): bounded offsets, no overflow
                const double ex = x + u - xb, ey = y + v - yb;
                moved = std::sqrt(ex * ex + ey * ey) > kMinImageMotion;
            }
            motions(y, x) = moved ? cv::Vec3f(static_cast<float>(obj[0]), static_cast<float>(obj[1]),
                                              static_cast<float>(obj[2]))
                                  : cv::Vec3f(kNaN, kNaN, kNaN);
            lands(y, x) = ty * w + tx;
        }
    cv::Mat3f objects = filled(h, w, cv::Vec3f(kNaN, kNaN, kNaN));
    cv::Mat1f nearest(h, w, 0.0f);  // d1 of the point written at each t1 pixel
    float *near = nearest.ptr<float>();
    cv::Vec3f *obj = objects.ptr<cv::Vec3f>();
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int t = lands(y, x);
            if (t < 0 || f.d1(y, x) <= near[t]) continue;
            near[t] = f.d1(y, x);
            obj[t] = motions(y, x);
        }
    for (int s = 1; s < steps; ++s) advance_one_step(objects, nearest, ego, camera);
    return close_gaps(objects, threads);
}

void add_object_motion(const motion::EgoMotion &m, const DisparityMap &d, const cv::Mat3f &objects, cv::Mat2f &prior,
                       int threads) {
    if (!m.valid || !m.calibrated || objects.size() != d.size() || prior.size() != d.size()) return;
    const StereoCamera &c = m.camera;
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x) {
            if (!finite3(objects(y, x)) || !disparity_valid(d(y, x)) || !(d(y, x) > 0.0f)) continue;
            const cv::Vec3f o = next_step(m.R, objects(y, x));
            double p[3], q[3], tx, ty;
            back_project(c, x, y, d(y, x), p);
            rigid(m.R, m.t, p, q);
            for (int i = 0; i < 3; ++i) q[i] += o[i];
            if (project(c, q, tx, ty)) prior(y, x) = cv::Vec2f(static_cast<float>(tx - x), static_cast<float>(ty - y));
        }
}

cv::Mat3f reverse_object_motion(const cv::Mat3f &objects, const cv::Mat2f &flow, const motion::EgoMotion &m,
                                int threads) {
    if (objects.empty() || objects.size() != flow.size() || !m.valid || !m.calibrated) return {};
    cv::Mat3f back = filled(objects.size(), cv::Vec3f(kNaN, kNaN, kNaN));
    for (int y = 0; y < objects.rows; ++y)
        for (int x = 0; x < objects.cols; ++x) {
            const cv::Vec3f o = objects(y, x);
            const cv::Vec2f f = flow(y, x);
            if (!finite3(o) || !std::isfinite(f[0]) || !std::isfinite(f[1])) continue;
            int tx, ty;
            if (!nearest_inside(x + f[0], y + f[1], back.cols, back.rows, tx, ty)) continue;
            // This step's object motion is R o (next_step); X0 = R^T (X1 - t - R o), so the way
            // back's is -o.
            back(ty, tx) = -o;
        }
    return close_gaps(back, threads);
}

CarriedLidar carry_static_points(const SparseLidar &points, const std::vector<uint8_t> &age,
                                 const SceneFlowField &field, const motion::EgoMotion &ego, int max_age) {
    CarriedLidar out;
    out.points = SparseLidar{points.width, points.height, {}};
    if (!ego.valid || !ego.calibrated || max_age < 1 || field.u.empty() || age.size() != points.points.size())
        return out;
    const cv::Size size(points.width, points.height);
    cv::Mat1f nearest(size, 0.0f);
    cv::Mat1b older(size, static_cast<uchar>(0));
    for (size_t i = 0; i < points.points.size(); ++i) {
        const LidarPoint &p = points.points[i];
        if (age[i] >= max_age || p.x < 0 || p.y < 0 || p.x >= field.width() || p.y >= field.height() ||
            !field.valid(p.y, p.x))
            continue;
        float d1 = 0, u = 0, v = 0;
        if (!ego.predict(static_cast<float>(p.x), static_cast<float>(p.y), p.disparity, d1, u, v) || !(d1 > 0.0f) ||
            d1 > kMaxLidarDisparity)
            continue;
        const float eu = field.u(p.y, p.x) - u, ev = field.v(p.y, p.x) - v;
        if (std::sqrt(eu * eu + ev * ev) > kMinImageMotion ||
            std::fabs(field.d1(p.y, p.x) - d1) > kMinImageMotion)
            continue;
        int tx = 0, ty = 0;
        if (!lidar::nearest_pixel(p.x + u, p.y + v, size, tx, ty) || d1 <= nearest(ty, tx)) continue;
        nearest(ty, tx) = d1;
        older(ty, tx) = static_cast<uint8_t>(age[i] + 1);
    }
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
            if (older(y, x)) {
                out.points.points.push_back({x, y, nearest(y, x)});
                out.age.push_back(older(y, x));
            }
    return out;
}

SparseLidar merge_carried(const SparseLidar &measured, const CarriedLidar &carried, const DisparityMap &d,
                          float tolerance, std::vector<uint8_t> &age) {
    SparseLidar out = measured;
    age.assign(measured.points.size(), 0);
    if (carried.empty() || carried.points.width != measured.width || carried.points.height != measured.height ||
        d.size() != cv::Size(measured.width, measured.height))
        return out;
    const DisparityMap held = measured.to_map();
    for (size_t i = 0; i < carried.points.points.size(); ++i) {
        const LidarPoint &p = carried.points.points[i];
        if (disparity_valid(held(p.y, p.x)) || !disparity_valid(d(p.y, p.x)) ||
            std::fabs(d(p.y, p.x) - p.disparity) > tolerance)
            continue;
        out.points.push_back(p);
        age.push_back(carried.age[i]);
    }
    return out;
}

}  // namespace lidarflow::matching
