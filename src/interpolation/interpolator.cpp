// SPDX-License-Identifier: MIT
#include "interpolation/interpolator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include <omp.h>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/log.hpp"
#include "core/maps.hpp"
#include "core/parallel_errors.hpp"
#include "core/pixels.hpp"
#include "core/random.hpp"
#include "core/threads.hpp"
#include "interpolation/chamfer_distance.hpp"
#include "interpolation/geodesic.hpp"
#include "interpolation/lidar_anchors.hpp"
#include "interpolation/lidar_residuals.hpp"
#include "interpolation/piecewise_model.hpp"
#include "interpolation/planar_merge.hpp"
#include "motion/ego_motion.hpp"

namespace lidarflow::interpolation {

using motion::EgoMotion;
using motion::EgoMotionOptions;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

enum Channel { kD0 = 0, kD1 = 1, kFlow = 2, kNumChannels = 3 };
constexpr int kDims[kNumChannels] = {1, 1, 2};

// The sparse input as a flat list: valid matches (raster order), then, with LiDAR on, the
// LiDAR pixels whose match did not survive (they still carry the measured d0).
struct Seeds {
    std::vector<cv::Point> pos;
    std::vector<float> x, y, u, v, d0, d1;
    // What is interpolated (see InterpolationOptions::d1_from_change / ego_motion): the
    // matches minus the background prediction from their own d0 (d0_match).
    std::vector<float> z1, zu, zv, d0_match;
    std::vector<uint8_t> has_motion, is_lidar, is_hint;
    int size() const { return static_cast<int>(pos.size()); }
    void reserve(size_t n) {
        pos.reserve(n);
        for (auto *a : {&x, &y, &u, &v, &d0, &d1, &z1, &zu, &zv, &d0_match}) a->reserve(n);
        for (auto *a : {&has_motion, &is_lidar, &is_hint}) a->reserve(n);
    }
    void push(int px, int py, float uu, float vv, float dd0, float dd1, bool motion, bool lidar,
              bool hint = false) {
        pos.emplace_back(px, py);
        x.push_back(static_cast<float>(px));
        y.push_back(static_cast<float>(py));
        u.push_back(uu);
        v.push_back(vv);
        d0.push_back(dd0);
        d1.push_back(dd1);
        z1.push_back(dd1);
        zu.push_back(uu);
        zv.push_back(vv);
        d0_match.push_back(dd0);
        has_motion.push_back(motion);
        is_lidar.push_back(lidar);
        is_hint.push_back(hint);
    }
    // How far seed i moves on its own, beyond the background motion (its flow remainder).
    float own_flow(int i) const { return std::sqrt(zu[i] * zu[i] + zv[i] * zv[i]); }
    // A LiDAR d0 measurement at (px, py): it replaces the d0 of a match on the same pixel (the
    // measurement is exact, the matched d0 is not) or becomes a seed of its own. False, and
    // nothing changed, when a LiDAR measurement already holds the pixel: the first one wins.
    bool add_lidar(cv::Mat1i &seed_at, int px, int py, float dd0) {
        const int id = seed_at(py, px);
        if (id >= 0 && is_lidar[id]) return false;
        if (id >= 0) {
            d0[id] = dd0;
            is_lidar[id] = 1;
        } else {
            seed_at(py, px) = size();
            push(px, py, 0.0f, 0.0f, dd0, 0.0f, false, true);
        }
        return true;
    }
};

void validate_options(const InterpolationOptions &o) {
    auto positive = [](float f) { return std::isfinite(f) && f > 0.0f; };
    require(std::isfinite(o.edge_gain) && o.edge_gain >= 0.0f, ErrorCode::InvalidArgument,
            "interpolation: edge_gain must be finite and >= 0");
    require(o.num_neighbors >= 1 && o.num_neighbors <= 4096, ErrorCode::InvalidArgument,
            "interpolation: num_neighbors must be in [1, 4096]");
    require(positive(o.distance_sigma), ErrorCode::InvalidArgument, "interpolation: distance_sigma must be > 0");
    require(positive(o.disparity_inlier) && positive(o.flow_inlier), ErrorCode::InvalidArgument,
            "interpolation: inlier thresholds must be > 0");
    require(o.initial_hypotheses >= 1 && o.initial_hypotheses <= 10000, ErrorCode::InvalidArgument,
            "interpolation: initial_hypotheses must be in [1, 10000]");
    require(o.iterations >= 0 && o.iterations <= 1000, ErrorCode::InvalidArgument,
            "interpolation: iterations must be in [0, 1000]");
    require(o.random_hypotheses >= 0 && o.random_hypotheses <= 10000, ErrorCode::InvalidArgument,
            "interpolation: random_hypotheses must be in [0, 10000]");
    require(std::isfinite(o.lidar_anchor_distance) && o.lidar_anchor_distance >= 0.0f,
            ErrorCode::InvalidArgument, "interpolation: lidar_anchor_distance must be >= 0");
    require(positive(o.lidar_disparity_tolerance) && positive(o.lidar_match_tolerance),
            ErrorCode::InvalidArgument, "interpolation: LiDAR tolerances must be > 0");
    require(positive(o.lidar_weight), ErrorCode::InvalidArgument, "interpolation: lidar_weight must be > 0");
    require(positive(o.occlusion_margin), ErrorCode::InvalidArgument, "interpolation: occlusion_margin must be > 0");
    require(positive(o.static_flow_tolerance), ErrorCode::InvalidArgument,
            "interpolation: static_flow_tolerance must be > 0");
    require(std::isfinite(o.static_d1_discrimination) && o.static_d1_discrimination >= 0.0f,
            ErrorCode::InvalidArgument, "interpolation: static_d1_discrimination must be finite and >= 0");
    require(o.lidar1_check_radius >= 0 && o.lidar1_check_radius <= 1000, ErrorCode::InvalidArgument,
            "interpolation: lidar1_check_radius must be in [0, 1000]");
    require(positive(o.lidar1_relative_tolerance), ErrorCode::InvalidArgument,
            "interpolation: lidar1_relative_tolerance must be > 0");
    require(positive(o.background_preference) && o.background_preference <= 1.0f, ErrorCode::InvalidArgument,
            "interpolation: background_preference must be in (0, 1]");
    const EgoMotionOptions &e = o.ego;
    require(e.hypotheses >= 1 && e.hypotheses <= 100000, ErrorCode::InvalidArgument,
            "interpolation: ego.hypotheses must be in [1, 100000]");
    require(positive(e.disparity_inlier) && positive(e.flow_inlier), ErrorCode::InvalidArgument,
            "interpolation: ego inlier thresholds must be > 0");
    require(std::isfinite(e.min_inlier_share) && e.min_inlier_share >= 0.0f && e.min_inlier_share <= 1.0f,
            ErrorCode::InvalidArgument, "interpolation: ego.min_inlier_share must be in [0, 1]");
    require(e.min_inliers >= 0 && e.min_inliers <= 100000000, ErrorCode::InvalidArgument,
            "interpolation: ego.min_inliers must be in [0, 10^8]");
    require(e.joint_rounds >= 0 && e.joint_rounds <= 100, ErrorCode::InvalidArgument,
            "interpolation: ego.joint_rounds must be in [0, 100]");
    require(o.hint_grid >= 1 && o.hint_grid <= 4096, ErrorCode::InvalidArgument,
            "interpolation: hint_grid must be in [1, 4096]");
    require(std::isfinite(o.hint_min_distance) && o.hint_min_distance >= 0.0f, ErrorCode::InvalidArgument,
            "interpolation: hint_min_distance must be finite and >= 0");
    require(positive(o.hint_weight) && positive(o.hint_lidar_tolerance), ErrorCode::InvalidArgument,
            "interpolation: hint_weight and hint_lidar_tolerance must be > 0");
    require(positive(o.hint_lidar_radius) && o.hint_lidar_radius <= 4096.0f, ErrorCode::InvalidArgument,
            "interpolation: hint_lidar_radius must be in (0, 4096]");
    require(o.num_threads >= 1 && o.num_threads <= 1024, ErrorCode::InvalidArgument,
            "interpolation: num_threads must be in [1, 1024]");
    // Sub-stage options are checked by their own functions; check them up front too so a bad
    // configuration fails at construction, not on the first frame.
    require(o.superpixels.region_size >= 4 && o.superpixels.region_size <= 512, ErrorCode::InvalidArgument,
            "interpolation: superpixels.region_size must be in [4, 512]");
    require(std::isfinite(o.lidar_points_per_superpixel) && o.lidar_points_per_superpixel >= 0.0f &&
                o.lidar_points_per_superpixel <= 10000.0f,
            ErrorCode::InvalidArgument, "interpolation: lidar_points_per_superpixel must be in [0, 10000]");
    require(std::isfinite(o.planar_merge_tolerance) && o.planar_merge_tolerance >= 0.0f &&
                o.planar_merge_tolerance <= 100.0f,
            ErrorCode::InvalidArgument, "interpolation: planar_merge_tolerance must be in [0, 100]");
    require(o.min_superpixel_size >= 4 && o.min_superpixel_size <= 512, ErrorCode::InvalidArgument,
            "interpolation: min_superpixel_size must be in [4, 512]");
    require(std::isfinite(o.lidar_residual_radius) && o.lidar_residual_radius >= 0.0f &&
                o.lidar_residual_radius <= 64.0f,
            ErrorCode::InvalidArgument, "interpolation: lidar_residual_radius must be in [0, 64]");
    require(std::isfinite(o.superpixels.compactness) && o.superpixels.compactness > 0.0f,
            ErrorCode::InvalidArgument, "interpolation: superpixels.compactness must be > 0");
    require(o.superpixels.iterations >= 1 && o.superpixels.iterations <= 100, ErrorCode::InvalidArgument,
            "interpolation: superpixels.iterations must be in [1, 100]");
    require(std::isfinite(o.edges.base_sigma) && o.edges.base_sigma > 0.0f && o.edges.base_sigma <= 16.0f,
            ErrorCode::InvalidArgument, "interpolation: edges.base_sigma must be in (0, 16]");
    require(positive(o.edges.contrast_gain), ErrorCode::InvalidArgument,
            "interpolation: edges.contrast_gain must be > 0");
}

Seeds collect_seeds(const SceneFlowField &m, const SparseLidar &lidar, bool use_lidar, cv::Mat1i &seed_at) {
    const int w = m.width(), h = m.height();
    seed_at.create(h, w);
    seed_at.setTo(-1);
    Seeds s;
    // Room for every match and point up front: a scan's ~30k seeds grew fourteen arrays by doubling.
    s.reserve(static_cast<size_t>(cv::countNonZero(m.valid)) + (use_lidar ? lidar.points.size() : 0));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!m.valid(y, x)) continue;
            const float u = m.u(y, x), v = m.v(y, x), d0 = m.d0(y, x), d1 = m.d1(y, x);
            require(std::isfinite(u) && std::isfinite(v) && std::isfinite(d0) && std::isfinite(d1),
                    ErrorCode::InvalidArgument, "interpolation: non-finite value in a valid match");
            require(d0 >= 0.0f && d1 >= 0.0f, ErrorCode::InvalidArgument,
                    "interpolation: negative disparity in a valid match");
            seed_at(y, x) = s.size();
            s.push(x, y, u, v, d0, d1, true, false);
        }
    require(s.size() > 0, ErrorCode::InvalidArgument, "interpolation: no valid match to interpolate");
    if (!use_lidar) return s;
    for (const LidarPoint &p : lidar.points) s.add_lidar(seed_at, p.x, p.y, p.disparity);
    return s;
}

void validate_lidar(const SparseLidar &lidar, const cv::Size &sz, const std::string &what) {
    if (lidar.points.empty()) return;
    require(lidar.width == sz.width && lidar.height == sz.height, ErrorCode::SizeMismatch,
            "interpolation: " + what + " and reference image differ in size");
    for (const LidarPoint &p : lidar.points) {
        require(p.x >= 0 && p.y >= 0 && p.x < sz.width && p.y < sz.height, ErrorCode::InvalidArgument,
                "interpolation: " + what + " point outside the image");
        require(std::isfinite(p.disparity) && p.disparity >= 0.0f, ErrorCode::InvalidArgument,
                "interpolation: " + what + " disparity must be finite and >= 0");
    }
}

void validate_inputs(const SceneFlowField &m, const SparseLidar &lidar, const cv::Mat &image) {
    require(!image.empty(), ErrorCode::InvalidArgument, "interpolation: empty reference image");
    require(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3),
            ErrorCode::InvalidArgument, "interpolation: reference image must be 8-bit gray or BGR");
    const cv::Size sz = image.size();
    require(!m.valid.empty() && !m.u.empty(), ErrorCode::InvalidArgument, "interpolation: empty match field");
    for (const cv::Mat *mat : {&static_cast<const cv::Mat &>(m.u), &static_cast<const cv::Mat &>(m.v),
                               &static_cast<const cv::Mat &>(m.d0), &static_cast<const cv::Mat &>(m.d1),
                               &static_cast<const cv::Mat &>(m.valid)})
        require(mat->size() == sz, ErrorCode::SizeMismatch,
                "interpolation: match field and reference image differ in size");
    validate_lidar(lidar, sz, "LiDAR");
}

void validate_hint(const DisparityMap &hint, const cv::Size &sz) {
    if (hint.empty()) return;
    require(hint.size() == sz, ErrorCode::SizeMismatch, "interpolation: geometry hint and image differ in size");
    for (int y = 0; y < hint.rows; ++y)
        for (int x = 0; x < hint.cols; ++x)
            require(std::isfinite(hint(y, x)), ErrorCode::InvalidArgument,
                    "interpolation: non-finite value in the geometry hint");
}

// The background model's prediction (EgoMotion::predict) for every seed from its disparity `d0`,
// in bands on `threads` threads.
struct Background {
    std::vector<float> d1, u, v;
};
Background predict_background(const Seeds &s, const std::vector<float> &d0, const EgoMotion &ego, int threads) {
    const int n = s.size();
    Background b{std::vector<float>(static_cast<size_t>(n)), std::vector<float>(static_cast<size_t>(n)),
                 std::vector<float>(static_cast<size_t>(n))};
    for_each_band(n, std::max(1, threads), [&](int, int i0, int i1) {
        ego.predict_many(s.x.data() + i0, s.y.data() + i0, d0.data() + i0, i1 - i0, b.d1.data() + i0,
                         b.u.data() + i0, b.v.data() + i0);
    });
    return b;
}

// Matches of points hidden at t1 (InterpolationOptions::occlusion_reasoning). Every match is
// splatted into two t1 depth buffers, the left image at its measured landing pixel
// (x + u, y + v) and the right image at (x + u - d1, y + v), with min(d0, d1): a hidden
// point's own wrong d1 (the occluder's) then cannot hide its neighbours, its d0 is still its
// own. A match is hidden in a view when the buffer at the pixel the background model predicts
// for it is nearer than its predicted d1 by max(occlusion_margin, 10 %). Hidden in the left
// view: its flow and d1 were matched on the occluder and nothing measured says how it moves;
// with a rigid (calibrated) background model it is taken as static, remainder 0. (Without a
// camera the model may describe one non-rigid region only; there it is left alone.) Hidden in
// the right view (d1 matched on the occluder, e.g. beside a near object): d1 follows the
// background model if the measured flow says the point is static.
int release_occluded(Seeds &s, const EgoMotion &ego, int w, int h, const InterpolationOptions &o) {
    cv::Mat1f zl = filled(h, w, -1.0f), zr = filled(h, w, -1.0f);
    constexpr int r = 2;  // matches are ~3 px apart after sparsification; cover the gaps
    const int n = s.size(), T = std::max(1, std::min(o.num_threads, h));
    // Each thread splats into its own band of rows (a maximum: the order does not matter).
    for_each_band(h, T, [&](int, int y0, int y1) {
        auto splat = [&](cv::Mat1f &z, float fx, float fy, float val) {
            const int tx = static_cast<int>(std::lround(fx)), ty = static_cast<int>(std::lround(fy));
            for (int y = std::max(y0, ty - r); y <= std::min(y1 - 1, ty + r); ++y)
                for (int x = std::max(0, tx - r); x <= std::min(w - 1, tx + r); ++x) z(y, x) = std::max(z(y, x), val);
        };
        for (int i = 0; i < n; ++i) {
            if (!s.has_motion[i]) continue;
            const float val = std::min(s.d0[i], s.d1[i]);
            splat(zl, s.x[i] + s.u[i], s.y[i] + s.v[i], val);
            splat(zr, s.x[i] + s.u[i] - s.d1[i], s.y[i] + s.v[i], val);
        }
    });
    auto hidden = [&](const cv::Mat1f &z, float fx, float fy, float d) {
        const int tx = static_cast<int>(std::lround(fx)), ty = static_cast<int>(std::lround(fy));
        if (tx < 0 || ty < 0 || tx >= w || ty >= h) return false;
        return z(ty, tx) >= d + std::max(o.occlusion_margin, 0.1f * d);
    };
    const Background bg = predict_background(s, s.d0, ego, T);
    int released = 0;
#pragma omp parallel for num_threads(T) schedule(static) reduction(+ : released)
    for (int i = 0; i < n; ++i) {
        if (!s.has_motion[i]) continue;
        const float d1e = bg.d1[i], tx = s.x[i] + bg.u[i], ty = s.y[i] + bg.v[i];
        if (ego.calibrated && hidden(zl, tx, ty, d1e)) {
            s.z1[i] = s.zu[i] = s.zv[i] = 0.0f;
            ++released;
        } else if (hidden(zr, tx - d1e, ty, d1e) && s.own_flow(i) < o.flow_inlier) {
            s.z1[i] = 0.0f;
            ++released;
        }
    }
    return released;
}

// Matches the rigid background explains by their flow take its d1 (see
// InterpolationOptions::static_d1_from_background). Runs on the remainders, after
// release_occluded.
int release_static_d1(Seeds &s, const EgoMotion &ego, const InterpolationOptions &o) {
    int released = 0;
    for (int i = 0; i < s.size(); ++i) {
        if (!s.has_motion[i] || s.z1[i] == 0.0f || s.own_flow(i) >= o.static_flow_tolerance) continue;
        // The background's prediction is the match minus its remainder (released matches,
        // whose remainders were zeroed, are skipped above).
        const float d1e = s.d1[i] - s.z1[i];
        const float r = std::hypot(s.x[i] + s.u[i] - s.zu[i] - static_cast<float>(ego.camera.cx),
                                   s.y[i] + s.v[i] - s.zv[i] - static_cast<float>(ego.camera.cy));
        // The floor keeps the ratio finite for points at infinity (d1e ~ 0).
        if (r * std::fabs(s.z1[i]) / std::max(d1e, 0.5f) < o.static_d1_discrimination) continue;
        s.z1[i] = 0.0f;
        ++released;
    }
    return released;
}

// t1 LiDAR points as d0 measurements at t0 (see InterpolationOptions::lidar1_from_background):
// the inverse background motion (EgoMotion::inverse) moves them back. A point is used unless
// the seeds around where it lands (matches and t0 LiDAR points) contradict it in the majority:
// by a motion of their own (matches) or by another depth.
// Runs after the remainders are final and before the hint seeds (which must not sit on it).
int add_lidar1_points(Seeds &s, cv::Mat1i &seed_at, const SparseLidar &lidar1, const EgoMotion &ego,
                      const InterpolationOptions &o) {
    const EgoMotion back = ego.inverse();
    const int w = seed_at.cols, h = seed_at.rows, r = o.lidar1_check_radius;
    const int voters_end = s.size();  // matches and t0 LiDAR points; points added here never vote
    int added = 0;
    for (const LidarPoint &q : lidar1.points) {
        if (q.disparity <= 0.0f) continue;  // at infinity: no depth to move
        float d0, u, v;
        if (!back.predict(static_cast<float>(q.x), static_cast<float>(q.y), q.disparity, d0, u, v)) continue;
        const float fx = q.x + u, fy = q.y + v;
        if (!(fx > -0.5f && fy > -0.5f && fx < w - 0.5f && fy < h - 0.5f)) continue;
        const int x = static_cast<int>(std::lround(fx)), y = static_cast<int>(std::lround(fy));
        if (seed_at(y, x) >= 0 && s.is_lidar[seed_at(y, x)]) continue;  // a t0 measurement wins
        const float tol = std::max(3.0f, o.lidar1_relative_tolerance * d0);
        int against = 0, total = 0;
        for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
            for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) {
                const int id = seed_at(yy, xx);
                if (id < 0 || id >= voters_end) continue;
                ++total;
                against += (s.has_motion[id] && s.own_flow(id) > o.flow_inlier) ||
                           std::fabs(s.d0[id] - d0) > tol;
            }
        if (2 * against > total) continue;
        added += s.add_lidar(seed_at, x, y, d0) ? 1 : 0;  // as a t0 measurement (collect_seeds)
    }
    return added;
}

// Geometry-hint seeds (see InterpolationOptions::use_geometry_hint): grid pixels in the holes
// of the matches where the LiDAR pixels around them confirm the hint. The hint is compared with
// LiDAR only at LiDAR pixels (same pixel, no slope assumption); a window vouches for its hint
// when at least 80 % of its comparable LiDAR pixels agree, so a single bad measurement (e.g.
// a LiDAR/camera parallax artefact) does not veto a whole region of dense scans.
int add_hint_seeds(Seeds &s, cv::Mat1i &seed_at, const DisparityMap &hint, const SparseLidar &lidar,
                   const InterpolationOptions &o) {
    const int w = hint.cols, h = hint.rows;
    cv::Mat1b not_match(h, w, uint8_t{255});
    for (int i = 0; i < s.size(); ++i)
        if (s.has_motion[i]) not_match(s.pos[i]) = 0;
    // The distance to the nearest match only at the grid's pixels, from the window that can hold
    // one closer than the bound; a bound beyond the image takes the whole map's transform (which
    // also gives its own large value where no match exists).
    const int reach = ChamferMask3::reach_below(o.hint_min_distance);
    cv::Mat1f dist;
    if (reach >= std::max(w, h)) cv::distanceTransform(not_match, dist, cv::DIST_L2, 3);
    const auto near_match = [&](int x, int y) {
        return (dist.empty() ? ChamferMask3::near(not_match, x, y, reach) : dist(y, x)) < o.hint_min_distance;
    };
    cv::Mat1b agree(h, w, uint8_t{0}), disagree(h, w, uint8_t{0});
    for (const LidarPoint &p : lidar.points) {
        const float d = hint(p.y, p.x);
        if (d < 0.0f) continue;
        (std::fabs(d - p.disparity) <= o.hint_lidar_tolerance ? agree : disagree)(p.y, p.x) = 1;
    }
    cv::Mat1i ia, id;  // (h + 1) x (w + 1) integral images
    cv::integral(agree, ia, CV_32S);
    cv::integral(disagree, id, CV_32S);
    const int r = static_cast<int>(o.hint_lidar_radius);
    auto box = [&](const cv::Mat1i &ii, int x, int y) {
        const int x0 = std::max(0, x - r), y0 = std::max(0, y - r);
        const int x1 = std::min(w, x + r + 1), y1 = std::min(h, y + r + 1);
        return ii(y1, x1) - ii(y0, x1) - ii(y1, x0) + ii(y0, x0);
    };
    int added = 0;
    const int g = o.hint_grid;
    for (int y = g / 2; y < h; y += g)
        for (int x = g / 2; x < w; x += g) {
            const float d = hint(y, x);
            if (d < 0.0f || seed_at(y, x) >= 0 || near_match(x, y)) continue;
            const int na = box(ia, x, y), nd = box(id, x, y);
            if (na == 0 || 5 * nd > na + nd) continue;
            seed_at(y, x) = s.size();
            s.push(x, y, 0.0f, 0.0f, d, 0.0f, false, false, true);
            ++added;
        }
    return added;
}

using Rng = SplitMix64;

uint64_t stream_seed(unsigned base, int sp, int iteration, int channel) {
    Rng r(base * 0x100000001B3ull ^ (static_cast<uint64_t>(sp) << 20) ^
          (static_cast<uint64_t>(iteration) << 8) ^ static_cast<uint64_t>(channel));
    return r.next();
}

// One neighbour list gathered for a superpixel: positions, weights, their running sum (for
// sampling) and the anchor's index (-1: none). d1 and the flow share the motion list.
struct Gathered {
    std::vector<float> x, y, w, cw;
    int anchor = -1;
};

// One superpixel's robust fitting problem for one channel: its list, and the channel's values.
struct Problem {
    int dims = 1;
    float tau = 1;
    const float *x = nullptr, *y = nullptr, *w = nullptr, *cw = nullptr;  // a Gathered list's
    int count = 0;
    std::vector<float> z0, z1;  // the channel's values at the list's seeds
    int anchor = -1;            // index into the arrays, or -1
    float anchor_tol = 0;
    float sx = 0, sy = 0;                     // superpixel centroid (perturbation pivot)
    float size = 16;
    // Cost factor of the all-zero model (the background model alone explains the seeds); 1 =
    // no preference. See InterpolationOptions::background_preference.
    float zero_factor = 1;
    int n() const { return count; }
    static bool is_zero(const Model &m) {
        for (const Plane &q : m.p)
            if (q.a != 0.0f || q.b != 0.0f || q.c != 0.0f) return false;
        return true;
    }
    float z(int i, int k) const { return k == 0 ? z0[i] : z1[i]; }
    float residual(const Model &m, int i) const {
        const float r0 = m.p[0].at(x[i], y[i]) - z0[i];
        if (dims == 1) return std::fabs(r0);
        const float r1 = m.p[1].at(x[i], y[i]) - z1[i];
        return std::sqrt(r0 * r0 + r1 * r1);
    }
    bool admissible(const Model &m) const { return anchor < 0 || residual(m, anchor) <= anchor_tol; }
    // Robust cost of m (piecewise_model.hpp, robust_lanes): eight lane sums added in a fixed order.
    float cost(const Model &m) const {
        constexpr int L = 8;
        float acc[L] = {};
        const int count = n();
        const int full = count - count % L;
        robust_lanes(m, dims, x, y, z0.data(), z1.data(), w, full, tau, acc);
        for (int i = full; i < count; ++i) acc[i - full] += w[i] * std::min(residual(m, i), tau);
        float c = 0;
        for (int k = 0; k < L; ++k) c += acc[k];
        return c;
    }
    int sample(Rng &rng) const {
        const float t = rng.uniform() * cw[count - 1];
        const int i = static_cast<int>(std::upper_bound(cw, cw + count, t) - cw);
        return std::min(i, n() - 1);
    }
    Model constant(int i) const {
        Model m;
        m.p[0].c = z0[i];
        m.p[1].c = dims == 2 ? z1[i] : 0.0f;
        return m;
    }
    // Affine model through three neighbours (the anchor first when there is one).
    bool random_affine(Rng &rng, Model &m) const {
        if (n() < 3) return false;
        int id[3];
        id[0] = anchor >= 0 ? anchor : sample(rng);
        for (int k = 1; k < 3; ++k) {
            int tries = 0;
            do {
                id[k] = sample(rng);
            } while ((id[k] == id[0] || (k == 2 && id[k] == id[1])) && ++tries < 8);
            if (tries >= 8) return false;
        }
        const float px[3] = {x[id[0]], x[id[1]], x[id[2]]}, py[3] = {y[id[0]], y[id[1]], y[id[2]]};
        for (int k = 0; k < dims; ++k) {
            const float pz[3] = {z(id[0], k), z(id[1], k), z(id[2], k)};
            if (!plane_from_3(px, py, pz, m.p[k])) return false;
        }
        return true;
    }
    // Weighted least squares on the inliers of m; the anchor, if any, dominates.
    bool refine(const Model &m, Model &out) const {
        PlaneLsq lsq(sx, sy);
        float zz[2];
        float wsum = 0;
        for (int i = 0; i < n(); ++i) {
            if (residual(m, i) >= tau) continue;
            zz[0] = z0[i];
            zz[1] = dims == 2 ? z1[i] : 0.0f;
            lsq.add(x[i], y[i], w[i], zz, dims);
            wsum += w[i];
        }
        if (anchor >= 0) {
            zz[0] = z0[anchor];
            zz[1] = dims == 2 ? z1[anchor] : 0.0f;
            lsq.add(x[anchor], y[anchor], 10.0f * wsum + 1.0f, zz, dims);
        }
        return lsq.solve(dims, out);
    }
    float inlier_share(const Model &m) const {
        float in = 0, all = 0;
        for (int i = 0; i < n(); ++i) {
            all += w[i];
            if (residual(m, i) < tau) in += w[i];
        }
        return all > 0 ? in / all : 0.0f;
    }
};

struct Candidate {
    Model m;
    float cost = std::numeric_limits<float>::infinity();
};

void consider(const Problem &p, const Model &m, Candidate &best) {
    if (!p.admissible(m)) return;
    const float c = p.cost(m) * (Problem::is_zero(m) ? p.zero_factor : 1.0f);
    if (c < best.cost) {
        best.cost = c;
        best.m = m;
    }
}

// Random search: the current model tilted and shifted around the superpixel centre, with a
// radius that halves every round.
Model perturb(const Problem &p, const Model &m, float radius, Rng &rng) {
    Model out = m;
    for (int k = 0; k < p.dims; ++k) {
        const float base = m.p[k].at(p.sx, p.sy) + radius * (2.0f * rng.uniform() - 1.0f);
        out.p[k].a += radius / p.size * (2.0f * rng.uniform() - 1.0f);
        out.p[k].b += radius / p.size * (2.0f * rng.uniform() - 1.0f);
        out.p[k].c = base - out.p[k].a * p.sx - out.p[k].b * p.sy;
    }
    return out;
}

// The seeds and the flags every later phase reads.
struct SeedSet {
    Seeds seeds;
    cv::Mat1i seed_at;         // seed index per pixel, -1 where none
    bool use_lidar = false;    // LiDAR on and D_l^0 has points
    bool subtract_d0 = false;  // the d1 and flow models describe the remainder after the background
    bool background = false;   // "no remainder" is a hypothesis of the d1 and flow models
};

// Phase 1: the seeds and the background model. Fits the ego-motion, subtracts its prediction
// from the matches, releases hidden and static matches to it and adds the t1 LiDAR points and
// the geometry hint's seeds. Sets res.ego and the seed counts of res.
SeedSet prepare_seeds(const SceneFlowField &matches, const SparseLidar &lidar0, const SparseLidar &lidar1,
                      const DisparityMap &geometry_hint, const StereoCamera &camera, int w, int h,
                      const InterpolationOptions &o, InterpolationResult &res) {
    SeedSet set;
    set.use_lidar = o.use_lidar && !lidar0.points.empty();
    const bool use_lidar = set.use_lidar;
    cv::Mat1i &seed_at = set.seed_at;
    Seeds &seeds = set.seeds;
    seeds = collect_seeds(matches, lidar0, use_lidar, seed_at);
    // Background prediction, subtracted from the matches here and added back per pixel from
    // the dense d0. The match's own d0 is used: its d1 and flow were measured with it, so the
    // residual stays consistent even where LiDAR replaces d0.
    const bool rigid = o.rigid_ego_motion && camera.valid();
    if (o.ego_motion) {
        EgoMotionOptions eo = o.ego;
        eo.seed = o.random_seed;
        eo.threads = o.num_threads;
        std::vector<float> mx, my, md0, md1, mu, mv;
        for (int i = 0; i < seeds.size(); ++i)
            if (seeds.has_motion[i]) {
                mx.push_back(seeds.x[i]), my.push_back(seeds.y[i]);
                md0.push_back(rigid && o.ego_lidar_depth ? seeds.d0[i] : seeds.d0_match[i]);
                md1.push_back(seeds.d1[i]), mu.push_back(seeds.u[i]), mv.push_back(seeds.v[i]);
            }
        res.ego = rigid ? motion::fit_rigid_ego_motion(mx, my, md0, md1, mu, mv, eo, camera)
                        : motion::fit_ego_motion(mx, my, md0, md1, mu, mv, eo);
        if (!res.ego.valid)
            log::write(log::Level::Warning, "interpolation: no background motion fits the " + std::to_string(mx.size()) +
                                                " matches; the frame is interpolated without it (no background "
                                                "hypothesis, occlusion reasoning or background d1)");
    }
    set.subtract_d0 = o.d1_from_change || res.ego.valid;
    // The zero remainder (pure background) is a hypothesis of its own only with a background
    // model to fall back on.
    set.background = res.ego.valid && o.background_hypothesis;
    if (set.subtract_d0) {
        const Background bg = predict_background(seeds, seeds.d0_match, res.ego, o.num_threads);
#pragma omp parallel for num_threads(o.num_threads) schedule(static)
        for (int i = 0; i < seeds.size(); ++i) {
            if (!seeds.has_motion[i]) continue;
            seeds.z1[i] = seeds.d1[i] - bg.d1[i];
            seeds.zu[i] = seeds.u[i] - bg.u[i];
            seeds.zv[i] = seeds.v[i] - bg.v[i];
        }
    }
    if (res.ego.valid && o.occlusion_reasoning) res.occluded_seeds = release_occluded(seeds, res.ego, w, h, o);
    if (res.ego.valid && res.ego.calibrated && o.static_d1_from_background)
        res.static_d1_seeds = release_static_d1(seeds, res.ego, o);
    if (res.ego.valid && res.ego.calibrated && use_lidar && o.lidar1_from_background)
        res.lidar1_points = add_lidar1_points(seeds, seed_at, lidar1, res.ego, o);
    // After the ego-motion fit: hints carry no motion.
    if (use_lidar && o.use_geometry_hint && !geometry_hint.empty())
        res.hint_seeds = add_hint_seeds(seeds, seed_at, geometry_hint, lidar0, o);
    return set;
}

// Phase 2a: the superpixels of the image on `threads` threads; below the largest size (a dense
// scan), those on one LiDAR plane or out of its reach merged back up to its area.
Superpixels segment(const cv::Mat &image, const DisparityMap &geometry_hint, const SeedSet &set, int largest,
                    const InterpolationOptions &o, int threads, InterpolationResult &res) {
    const auto t = Clock::now();
    SuperpixelOptions spo = o.superpixels;
    spo.num_threads = threads;
    const bool scan_sized = spo.region_size < largest;
    // Depth only where a dense scan sized them: without one the stereo's depth is the images' own.
    if (!scan_sized) spo.disparity_weight = 0.0f;
    Superpixels sp = compute_superpixels(image, spo, geometry_hint);
    if (set.use_lidar && (o.planar_merge_tolerance > 0.0f || o.merge_unseen) && scan_sized) {
        std::vector<cv::Point> pos;
        std::vector<float> disparity;
        for (int i = 0; i < set.seeds.size(); ++i)
            if (set.seeds.is_lidar[i]) {
                pos.push_back(set.seeds.pos[i]);
                disparity.push_back(set.seeds.d0[i]);
            }
        PlanarMergeOptions pm;
        pm.tolerance = o.planar_merge_tolerance;
        pm.unseen = o.merge_unseen;
        pm.max_area = largest * largest;
        pm.threads = threads;
        sp = merge_planar_superpixels(sp, pos, disparity, pm);
    }
    res.superpixels = sp.labels;
    res.num_superpixels = sp.count;
    res.timings.superpixels_s = seconds_since(t);
    return sp;
}

// Phase 2b: the edge map (res.edges; `edges` when computed ahead, else null) and the seed graph
// over it (its time the start of res.timings.geodesic_s), its links on `threads` threads. Serial
// but for OpenCV's filters and those links.
SeedGraph edges_and_graph(const cv::Mat &image, const SedModel *sed, const Seeds &seeds, const InterpolationOptions &o,
                          const cv::Mat1f *edges, int threads, InterpolationResult &res) {
    auto t = Clock::now();
    res.edges = edges ? *edges : compute_edge_map(image, o.edges, sed);
    res.timings.edges_s = seconds_since(t);
    t = Clock::now();
    SeedGraph graph = build_seed_graph(res.edges, seeds.pos, o.edge_gain, threads);
    res.timings.geodesic_s = seconds_since(t);
    return graph;
}

// Phase 2: 2a beside 2b. Both are largely serial and neither reads the other's result, so with
// two threads or more they run side by side (the superpixels' own regions, nested, then take one
// thread unless the application enabled nesting); on OpenMP's worker, whose heap already holds
// what stage 4's other phases freed, not on a thread of their own. The same results on any
// thread count.
// With `work` (the image's, for this superpixel size) its edges and superpixels are taken as
// they are.
Superpixels segment_beside_graph(const cv::Mat &image, const DisparityMap &geometry_hint, const SedModel *sed,
                                 const SeedSet &set, int largest, const InterpolationOptions &o, const ImageWork *work,
                                 InterpolationResult &res, SeedGraph &graph) {
    Superpixels sp;
    if (work && work->superpixels) {
        sp = *work->superpixels;
        res.superpixels = sp.labels;
        res.num_superpixels = sp.count;
        graph = edges_and_graph(image, sed, set.seeds, o, &work->edges, o.num_threads, res);
        return sp;
    }
    ParallelErrors errors;
#pragma omp parallel num_threads(2) if (o.num_threads > 1)
    {
        // The edges' many full-size planes on the calling thread, whose heap the earlier stages
        // freed; the worker's heap takes the superpixels' few.
        const int id = omp_get_thread_num(), team = omp_get_num_threads();
        const cv::Mat1f *edges = work ? &work->edges : nullptr;
        if (id == 0) errors.run([&] { graph = edges_and_graph(image, sed, set.seeds, o, edges, 1, res); });
        if (id == 1 || team == 1)
            errors.run([&] { sp = segment(image, geometry_hint, set, largest, o, std::max(1, o.num_threads - 1), res); });
    }
    errors.rethrow_if_any();
    return sp;
}

// Each superpixel's anchors and its geometry (d0) and motion (u, v, d1) neighbourhoods: lists of
// up to K (seed, geodesic distance), nearest first.
struct Neighbourhoods {
    SeedGraph graph;
    LidarAnchors anchors;
    std::vector<std::vector<std::pair<int, float>>> geo_nb, mot_nb;
};

// Phase 3: the LiDAR anchors and the K geodesically nearest seeds of each superpixel's anchors
// on phase 2b's seed graph. Sets the anchor counts of res.
Neighbourhoods find_neighbourhoods(const SeedSet &set, const Superpixels &sp, SeedGraph graph_in,
                                   const InterpolationOptions &o, InterpolationResult &res) {
    const Seeds &seeds = set.seeds;
    const auto t = Clock::now();
    Neighbourhoods n;
    n.graph = std::move(graph_in);
    const SeedGraph &graph = n.graph;
    LidarAnchors &anchors = n.anchors;
    anchors = set.use_lidar
                  ? associate_lidar(sp, seeds.pos, seeds.is_lidar, seeds.has_motion, o.lidar_anchor_distance)
                  : LidarAnchors::none(sp.count);
    if (!o.lidar_motion_anchors) std::fill(anchors.motion.begin(), anchors.motion.end(), -1);
    // Neighbourhoods, flat: geometry (d0) and motion (u, v, d1) lists of up to K seeds each.
    const int K = o.num_neighbors;
    auto &geo_nb = n.geo_nb, &mot_nb = n.mot_nb;
    geo_nb.resize(sp.count);
    mot_nb.resize(sp.count);
    ParallelErrors errors;
#pragma omp parallel num_threads(o.num_threads)
    {
        std::unique_ptr<SeedSearch> search;
        errors.run([&] { search = std::make_unique<SeedSearch>(seeds.size()); });
#pragma omp for schedule(dynamic, 16)
        for (int s = 0; s < sp.count; ++s) errors.run([&] {
            const int ga = anchors.geometry[s], ma = anchors.motion[s];
            const cv::Point gp = ga >= 0 ? seeds.pos[ga] : sp.anchor[s];
            const cv::Point mp = ma >= 0 ? seeds.pos[ma] : sp.anchor[s];
            const auto moving = [&](int i) { return seeds.has_motion[i] != 0; };
            if (gp == mp) {
                search->nearest_two(graph, gp, K, geo_nb[s], K, moving, mot_nb[s]);
            } else {
                search->nearest(graph, gp, K, [](int) { return true; }, geo_nb[s]);
                search->nearest(graph, mp, K, moving, mot_nb[s]);
            }
        });
    }
    errors.rethrow_if_any();
    res.timings.geodesic_s += seconds_since(t);
    for (int s = 0; s < sp.count; ++s) {
        res.lidar_anchored_geometry += anchors.geometry[s] >= 0;
        res.lidar_anchored_motion += anchors.motion[s] >= 0;
    }
    return n;
}

// The model of each (superpixel, channel), at s * kNumChannels + c, and its weighted inlier
// share over its neighbourhood.
struct Models {
    std::vector<Model> cur;
    std::vector<float> share;
};

// Phase 4: per superpixel and channel, the model from random hypotheses, propagation from the
// adjacent superpixels, random search and refinement.
Models fit_models(const SeedSet &set, const Superpixels &sp, const Neighbourhoods &n, const InterpolationOptions &o,
                  int max_hypotheses, InterpolationResult &res) {
    const Seeds &seeds = set.seeds;
    const bool use_lidar = set.use_lidar, background = set.background;
    const LidarAnchors &anchors = n.anchors;
    const auto &geo_nb = n.geo_nb, &mot_nb = n.mot_nb;
    const auto t = Clock::now();
    const int S = sp.count;
    Models models;
    std::vector<Model> &cur = models.cur;
    cur.resize(static_cast<size_t>(S) * kNumChannels);
    std::vector<Model> next(cur.size());
    std::vector<float> &share = models.share;
    share.assign(cur.size(), 0.0f);
    // The neighbourhoods do not change between rounds: gathered (and weighted) once. ~30 MB on
    // a KITTI frame, less than the matcher's peak, against 5x the exp() and gathers.
    std::vector<Gathered> lists(2 * static_cast<size_t>(S));  // per superpixel: geometry, motion
    std::vector<Problem> problems(cur.size());
    auto gather = [&](const std::vector<std::pair<int, float>> &nb, int anchor_seed, bool lidar_weighted,
                      Gathered &g) {
        const size_t n = nb.size();
        for (auto *v : {&g.x, &g.y, &g.w, &g.cw}) v->resize(n);
        // Written through plain pointers: push_back's size updates went through memory.
        float *px = g.x.data(), *py = g.y.data(), *pw = g.w.data(), *pc = g.cw.data();
        float acc = 0;
        for (size_t k = 0; k < n; ++k) {
            const int id = nb[k].first;
            if (id == anchor_seed) g.anchor = static_cast<int>(k);
            px[k] = seeds.x[id];
            py[k] = seeds.y[id];
            float wt = std::exp(-nb[k].second / o.distance_sigma);
            if (lidar_weighted && seeds.is_lidar[id]) wt *= o.lidar_weight;
            if (seeds.is_hint[id]) wt *= o.hint_weight;
            // Floor keeps far neighbours sampleable when the anchor sits in a sparse region.
            wt = std::max(wt, 1e-6f);
            pw[k] = wt;
            acc += wt;
            pc[k] = acc;
        }
    };
    auto build = [&](int s, int c, const Gathered &g, Problem &p) {
        const auto &nb = c == kD0 ? geo_nb[s] : mot_nb[s];
        p.dims = kDims[c];
        p.tau = c == kFlow ? o.flow_inlier : o.disparity_inlier;
        p.anchor_tol = c == kD0 ? o.lidar_disparity_tolerance : o.lidar_match_tolerance;
        p.anchor = g.anchor;
        p.zero_factor = background && c != kD0 ? o.background_preference : 1.0f;
        p.sx = sp.centroid[s].x;
        p.sy = sp.centroid[s].y;
        p.size = static_cast<float>(o.superpixels.region_size);
        p.x = g.x.data(), p.y = g.y.data(), p.w = g.w.data(), p.cw = g.cw.data();
        p.count = static_cast<int>(g.x.size());
        p.z0.resize(nb.size());
        const float *value = c == kD0 ? seeds.d0.data() : c == kD1 ? seeds.z1.data() : seeds.zu.data();
        for (size_t k = 0; k < nb.size(); ++k) p.z0[k] = value[nb[k].first];
        if (c == kFlow) {
            p.z1.resize(nb.size());
            for (size_t k = 0; k < nb.size(); ++k) p.z1[k] = seeds.zv[nb[k].first];
        }
    };
    ParallelErrors build_errors;
#pragma omp parallel for num_threads(o.num_threads) schedule(dynamic, 8)
    for (int s = 0; s < S; ++s) build_errors.run([&] {
        Gathered &geo = lists[2 * static_cast<size_t>(s)], &mot = lists[2 * static_cast<size_t>(s) + 1];
        gather(geo_nb[s], anchors.geometry[s], use_lidar, geo);
        gather(mot_nb[s], anchors.motion[s], false, mot);
        for (int c = 0; c < kNumChannels; ++c)
            build(s, c, c == kD0 ? geo : mot, problems[static_cast<size_t>(s) * kNumChannels + c]);
    });
    build_errors.rethrow_if_any();
    for (int it = 0; it <= o.iterations; ++it) {
        ParallelErrors iteration_errors;
#pragma omp parallel num_threads(o.num_threads)
        {
            Model m;
#pragma omp for schedule(dynamic, 8)
            for (int s = 0; s < S; ++s) iteration_errors.run([&] {
                for (int c = 0; c < kNumChannels; ++c) {
                    const size_t slot = static_cast<size_t>(s) * kNumChannels + c;
                    const Problem &p = problems[slot];
                    Rng rng(stream_seed(o.random_seed, s, it, c));
                    Candidate best;
                    if (it == 0) {
                        // Constants always exist, so a superpixel with < 3 usable neighbours
                        // (or only collinear ones) still gets a model.
                        consider(p, p.constant(p.anchor >= 0 ? p.anchor : 0), best);
                        if (background && c != kD0) consider(p, Model{}, best);
                        consider(p, p.constant(p.sample(rng)), best);
                        // A merged superpixel draws those of its parts, as a large one would.
                        const int hypotheses =
                            sp.parts.empty() ? o.initial_hypotheses
                                             : std::min(max_hypotheses, o.initial_hypotheses * sp.parts[s]);
                        for (int k = 0; k < hypotheses; ++k)
                            if (p.random_affine(rng, m)) consider(p, m, best);
                    } else {
                        consider(p, cur[slot], best);
                        for (int e = sp.adj_start[s]; e < sp.adj_start[s + 1]; ++e)
                            consider(p, cur[static_cast<size_t>(sp.adj[e]) * kNumChannels + c], best);
                        for (int k = 0; k < o.random_hypotheses; ++k)
                            if (p.random_affine(rng, m)) consider(p, m, best);
                        const float radius = p.tau * std::ldexp(1.0f, 1 - it);
                        consider(p, perturb(p, best.m, radius, rng), best);
                    }
                    for (int r = 0; r < 2; ++r) {
                        if (!p.refine(best.m, m)) break;
                        const float before = best.cost;
                        consider(p, m, best);
                        if (!(best.cost < before)) break;
                    }
                    next[slot] = best.m;
                    if (it == o.iterations) share[slot] = p.inlier_share(best.m);
                }
            });
        }
        iteration_errors.rethrow_if_any();
        std::swap(cur, next);
    }
    std::vector<Problem>().swap(problems);  // before the output's fields are allocated
    std::vector<Gathered>().swap(lists);
    res.timings.models_s = seconds_since(t);
    return models;
}

// The LiDAR residuals of the d0 models the pixels chose, spread over the pixels of the same
// model (InterpolationOptions::lidar_residual_radius); empty when off or without LiDAR.
cv::Mat1f lidar_residuals(const SeedSet &set, const cv::Mat1i &pair_of, const std::vector<int> &chosen,
                          const std::vector<Model> &cur, const InterpolationOptions &o) {
    // The model's own weight against a point on the pixel: near a point the measurement decides.
    constexpr float kModelWeight = 0.05f;
    const Seeds &seeds = set.seeds;
    if (!set.use_lidar || o.lidar_residual_radius <= 0.0f) return {};
    cv::Mat1i model_of(pair_of.size());
#pragma omp parallel for num_threads(o.num_threads) schedule(static)
    for (int y = 0; y < pair_of.rows; ++y)
        for (int x = 0; x < pair_of.cols; ++x)
            model_of(y, x) = chosen[static_cast<size_t>(pair_of(y, x)) * kNumChannels + kD0];
    std::vector<cv::Point> points;
    std::vector<float> residuals;
    for (int i = 0; i < seeds.size(); ++i)
        if (seeds.is_lidar[i]) {
            const Model &m = cur[static_cast<size_t>(model_of(seeds.pos[i])) * kNumChannels + kD0];
            points.push_back(seeds.pos[i]);
            residuals.push_back(seeds.d0[i] - m.p[0].at(seeds.x[i], seeds.y[i]));
        }
    return lidar_residual_correction(model_of, points, residuals, o.lidar_residual_radius, kModelWeight,
                                     o.num_threads);
}

// Seeds around a pixel, as the per-pixel model choice weighs them: position, the channel's
// value(s) and the graph edge's weight (1 for the pixel's own seed).
struct SupportPoints {
    std::vector<float> x, y, z, zu, zv, w;
    // The weights summed in order: no support exceeds it (a sum of a subset of non-negative
    // terms in the same order rounds to no more than the whole).
    float total = 0;
    void clear() {
        for (auto *v : {&x, &y, &z, &zu, &zv, &w}) v->clear();
        total = 0;
    }
    void push(float px, float py, float value, float wt) {
        x.push_back(px);
        y.push_back(py);
        z.push_back(value);
        w.push_back(wt);
        total += wt;
    }
    void push_flow(float u, float v) {
        zu.push_back(u);
        zv.push_back(v);
    }
    // The summed weight of the points model m (channel c) explains within tau, in order.
    float support(const Model &m, int c, float tau) const {
        float sc = 0;
        const size_t n = x.size();
        if (kDims[c] == 1) {
            for (size_t k = 0; k < n; ++k)
                if (std::fabs(m.p[0].at(x[k], y[k]) - z[k]) < tau) sc += w[k];
        } else {
            for (size_t k = 0; k < n; ++k) {
                const float r0 = m.p[0].at(x[k], y[k]) - zu[k], r1 = m.p[1].at(x[k], y[k]) - zv[k];
                if (std::sqrt(r0 * r0 + r1 * r1) < tau) sc += w[k];
            }
        }
        return sc;
    }
};

// Where each (seed, superpixel) pair sits in a list of pairs: find_or_add gives its place,
// appending it when new. Each seed's pairs are a list threaded through next_ (no allocation per
// seed).
class PairIndex {
public:
    explicit PairIndex(int seeds) : first_(static_cast<size_t>(seeds), -1) {}
    int find_or_add(int seed, int s, std::vector<std::pair<int, int>> &pairs) {
        int i = first_[static_cast<size_t>(seed)];
        while (i >= 0 && pairs[static_cast<size_t>(i)].second != s) i = next_[static_cast<size_t>(i)];
        if (i >= 0) return i;
        i = static_cast<int>(pairs.size());
        pairs.emplace_back(seed, s);
        next_.push_back(first_[static_cast<size_t>(seed)]);
        first_[static_cast<size_t>(seed)] = i;
        return i;
    }

private:
    std::vector<int> first_, next_;
};

// The distinct (nearest seed, superpixel) pairs in raster order of their first pixels, and each
// pixel's pair in `pair_of`. Each band of rows numbers its own pairs (rows are mostly long runs
// of one pair), then the bands' lists are merged in band order: the numbers a single raster scan
// gives, on any thread count.
std::vector<std::pair<int, int>> number_pairs(const cv::Mat1i &labels, const cv::Mat1i &nearest, int num_seeds,
                                              int threads, cv::Mat1i &pair_of) {
    const int h = labels.rows, w = labels.cols, T = std::max(1, std::min(threads, h));
    std::vector<std::vector<std::pair<int, int>>> local(static_cast<size_t>(T));
    std::vector<PairIndex> index(static_cast<size_t>(T), PairIndex(num_seeds));
    ParallelErrors errors;  // the bands' lists grow inside the region
    for_each_band(h, T, [&](int b, int y0, int y1) {
        errors.run([&] {
            std::vector<std::pair<int, int>> &mine = local[static_cast<size_t>(b)];
            for (int y = y0; y < y1; ++y) {
                int last_seed = -1, last_sp = -1, last_pair = -1;
                for (int x = 0; x < w; ++x) {
                    const int s = labels(y, x), seed = nearest(y, x);
                    if (seed != last_seed || s != last_sp) {
                        last_seed = seed;
                        last_sp = s;
                        last_pair = index[static_cast<size_t>(b)].find_or_add(seed, s, mine);
                    }
                    pair_of(y, x) = last_pair;
                }
            }
        });
    });
    errors.rethrow_if_any();
    if (T == 1) return std::move(local[0]);
    std::vector<std::pair<int, int>> pairs;
    std::vector<std::vector<int>> global(static_cast<size_t>(T));
    PairIndex merged(num_seeds);
    for (int b = 0; b < T; ++b)
        for (const auto &[seed, s] : local[static_cast<size_t>(b)])
            global[static_cast<size_t>(b)].push_back(merged.find_or_add(seed, s, pairs));
    for_each_band(h, T, [&](int b, int y0, int y1) {
        const std::vector<int> &to = global[static_cast<size_t>(b)];
        for (int y = y0; y < y1; ++y) {
            int *row = pair_of[y];
            for (int x = 0; x < w; ++x) row[x] = to[static_cast<size_t>(row[x])];
        }
    });
    return pairs;
}

// Phase 5: the dense field. Each pixel takes the models of its superpixel or of an adjacent
// one (pixel_model_selection), adds the background prediction back and, with LiDAR, keeps the
// measured d0 (keep_lidar_values).
void write_output(const SeedSet &set, const Superpixels &sp, const Neighbourhoods &n, const Models &models,
                  const SparseLidar &lidar0, int w, int h, const InterpolationOptions &o, InterpolationResult &res) {
    const Seeds &seeds = set.seeds;
    const cv::Mat1i &seed_at = set.seed_at;
    const bool use_lidar = set.use_lidar, subtract_d0 = set.subtract_d0;
    const SeedGraph &graph = n.graph;
    const LidarAnchors &anchors = n.anchors;
    const std::vector<Model> &cur = models.cur;
    const std::vector<float> &share = models.share;
    const auto t = Clock::now();
    res.dense = SceneFlowField::uninitialized(w, h);  // the pixel loop below writes every value
    res.dense.valid.setTo(1);
    // Per-pixel model choice: a pixel keeps its superpixel's model unless the matches around
    // it (its geodesically nearest seed and that seed's graph neighbours) are better explained
    // by the model of an adjacent superpixel. Superpixels coarser than thin structures (poles,
    // sign posts) would otherwise paint them with the background's model.
    // Decisions depend only on (nearest seed, superpixel): number the pairs that occur (rows
    // are mostly long runs of one pair), decide each pair once, then fill the pixels.
    cv::Mat1i pair_of(h, w);
    const std::vector<std::pair<int, int>> pairs =
        number_pairs(sp.labels, graph.nearest, seeds.size(), o.num_threads, pair_of);
    // A graph neighbour's weight depends only on the edge: once per edge, not per candidate.
    std::vector<float> edge_weight(graph.weight.size());
#pragma omp parallel for num_threads(o.num_threads) schedule(static)
    for (std::ptrdiff_t e = 0; e < static_cast<std::ptrdiff_t>(edge_weight.size()); ++e)
        edge_weight[static_cast<size_t>(e)] = std::exp(-graph.weight[static_cast<size_t>(e)] / o.distance_sigma);
    std::vector<int> chosen(pairs.size() * kNumChannels);
    ParallelErrors choice_errors;  // the gathers allocate
#pragma omp parallel num_threads(o.num_threads)
    {
        // The pair's seed and its graph neighbours, gathered once per pair (each is read by
        // every candidate model of every channel): geometry all of them, motion those with one.
        SupportPoints geo, mot;
#pragma omp for schedule(dynamic, 256)
        for (int pi = 0; pi < static_cast<int>(pairs.size()); ++pi) choice_errors.run([&] {
            // Plain names, not a structured binding: the lambdas below capture them (C++17).
            const int seed = pairs[pi].first, s = pairs[pi].second;
            geo.clear();
            mot.clear();
            if (o.pixel_model_selection) {
                auto add = [&](int id, float wt) {
                    geo.push(seeds.x[id], seeds.y[id], seeds.d0[id], wt);
                    if (seeds.has_motion[id]) {
                        mot.push(seeds.x[id], seeds.y[id], seeds.z1[id], wt);
                        mot.push_flow(seeds.zu[id], seeds.zv[id]);
                    }
                };
                add(seed, 1.0f);
                for (int e = graph.start[seed]; e < graph.start[seed + 1]; ++e) add(graph.nbr[e], edge_weight[e]);
            }
            for (int c = 0; c < kNumChannels; ++c) {
                int pick = s;
                // The LiDAR point's own cell keeps the anchored model: there the measurement is
                // the nearest evidence, whatever the matches around it say.
                const int anchor_seed = c == kD0 ? anchors.geometry[s] : anchors.motion[s];
                if (o.pixel_model_selection && seed != anchor_seed) {
                    const float tau = c == kFlow ? o.flow_inlier : o.disparity_inlier;
                    const SupportPoints &pts = c == kD0 ? geo : mot;
                    auto support = [&](int cand) {
                        return pts.support(cur[static_cast<size_t>(cand) * kNumChannels + c], c, tau);
                    };
                    // The own model wins ties: switching needs clearly more local support.
                    float best = support(s) + 0.5f;
                    // Where the own model explains nearly all, no other can win.
                    for (int e = sp.adj_start[s]; e < sp.adj_start[s + 1] && best < pts.total; ++e) {
                        const float sc = support(sp.adj[e]);
                        if (sc > best) {
                            best = sc;
                            pick = sp.adj[e];
                        }
                    }
                }
                chosen[static_cast<size_t>(pi) * kNumChannels + c] = pick;
            }
        });
    }
    choice_errors.rethrow_if_any();
    // Only the rigid model (camera known): it predicts where a background point goes from its
    // depth; the calibration-free one also explains independently moving regions that leave
    // the image (worse flow on the planar test scene of four motions).
    const bool exits_follow_background =
        o.exits_follow_background && subtract_d0 && res.ego.valid && res.ego.calibrated;
    const auto inside = [w, h](float tx, float ty) { return tx >= 0 && ty >= 0 && tx <= w - 1 && ty <= h - 1; };
    const cv::Mat1f correction = lidar_residuals(set, pair_of, chosen, cur, o);
    // The background's prediction a row at a time (EgoMotion::predict_many): columns, the row's
    // y, and per thread its d1, u and v, allocated before the region.
    std::vector<float> columns(static_cast<size_t>(w));
    for (int x = 0; x < w; ++x) columns[static_cast<size_t>(x)] = static_cast<float>(x);
    const int T = std::max(1, o.num_threads);
    std::vector<std::vector<float>> background(static_cast<size_t>(T),
                                               std::vector<float>(4 * static_cast<size_t>(w), 0.0f));
#pragma omp parallel for num_threads(T) schedule(static)
    for (int y = 0; y < h; ++y) {
        float *row_y = background[static_cast<size_t>(omp_get_thread_num())].data(), *d1e = row_y + w, *ue = d1e + w,
              *ve = ue + w;
        for (int x = 0; x < w; ++x) {
            const int pick = chosen[static_cast<size_t>(pair_of(y, x)) * kNumChannels + kD0];
            const Model &m0 = cur[static_cast<size_t>(pick) * kNumChannels + kD0];
            const float c0 = correction.empty() ? 0.0f : correction(y, x);
            res.dense.d0(y, x) = std::max(0.0f, m0.p[0].at(static_cast<float>(x), static_cast<float>(y)) + c0);
        }
        if (subtract_d0) {
            std::fill(row_y, row_y + w, static_cast<float>(y));
            res.ego.predict_many(columns.data(), row_y, res.dense.d0[y], w, d1e, ue, ve);
        }
        for (int x = 0; x < w; ++x) {
            const int *pick = &chosen[static_cast<size_t>(pair_of(y, x)) * kNumChannels];
            const float fx = static_cast<float>(x), fy = static_cast<float>(y);
            const Model &m1 = cur[static_cast<size_t>(pick[kD1]) * kNumChannels + kD1];
            const Model &mf = cur[static_cast<size_t>(pick[kFlow]) * kNumChannels + kFlow];
            const float d1b = d1e[x], ub = ue[x], vb = ve[x];
            float d1 = d1b + m1.p[0].at(fx, fy), u = ub + mf.p[0].at(fx, fy), v = vb + mf.p[1].at(fx, fy);
            // Leaving the image: no match can exist there, so the superpixel's model is an
            // extrapolation; when the background agrees that the point leaves, it decides.
            if (exits_follow_background && !inside(fx + ub, fy + vb) && !inside(fx + u, fy + v)) {
                d1 = d1b;
                u = ub;
                v = vb;
            }
            res.dense.d1(y, x) = std::max(0.0f, d1);
            res.dense.u(y, x) = u;
            res.dense.v(y, x) = v;
            const size_t base = static_cast<size_t>(sp.labels(y, x)) * kNumChannels;
            res.dense.confidence(y, x) = (share[base] + share[base + 1] + share[base + 2]) / 3.0f;
        }
    }
    if (use_lidar && o.keep_lidar_values)
        for (const LidarPoint &lp : lidar0.points) res.dense.d0(lp.y, lp.x) = seeds.d0[seed_at(lp.y, lp.x)];
    res.timings.output_s = seconds_since(t);
}

}  // namespace

int superpixel_size(const InterpolationOptions &o, size_t lidar_points, cv::Size image) {
    const int largest = o.superpixels.region_size;
    if (o.lidar_points_per_superpixel <= 0 || lidar_points == 0 || image.area() <= 0) return largest;
    const double per_pixel = static_cast<double>(lidar_points) / image.area();
    const double size = std::sqrt(o.lidar_points_per_superpixel / per_pixel);
    return size >= largest ? largest
                           : std::max(std::min(o.min_superpixel_size, largest), static_cast<int>(std::lround(size)));
}

int initial_hypotheses(int hypotheses, int size, int largest) {
    if (size >= largest || largest <= 0) return hypotheses;
    const double share = static_cast<double>(size) * size / (static_cast<double>(largest) * largest);
    return std::min(hypotheses, std::max(kMinInitialHypotheses, static_cast<int>(std::lround(hypotheses * share))));
}

RobustInterpolator::RobustInterpolator(const InterpolationOptions &options) : options_(options) {
    validate_options(options_);
    prepare_superpixels();
    if (options_.edges.method == EdgeMethod::StructuredForest)
        sed_ = std::make_shared<const SedModel>(options_.edges.sed_model_path);
}

ImageWork RobustInterpolator::prepare_image(const cv::Mat &image, size_t lidar_points, int threads) const {
    require(threads >= 0 && threads <= 1024, ErrorCode::InvalidArgument, "interpolation: threads must be in [0, 1024]");
    require(!image.empty(), ErrorCode::InvalidArgument, "interpolation: empty image");
    ImageWork w;
    w.image = image.clone();
    const int largest = options_.superpixels.region_size;
    w.region_size = superpixel_size(options_, options_.use_lidar ? lidar_points : 0, image.size());
    // Superpixels beside the edges, as run() computes them without a dense scan (no depth).
    const bool segments = w.region_size >= largest;
    const int n = threads > 0 ? threads : options_.num_threads;
    ParallelErrors errors;
#pragma omp parallel num_threads(2) if (n > 1 && segments)
    {
        const int id = omp_get_thread_num(), team = omp_get_num_threads();
        if (id == 0) errors.run([&] { w.edges = compute_edge_map(image, options_.edges, sed_.get()); });
        if (segments && (id == 1 || team == 1))
            errors.run([&] {
                SuperpixelOptions spo = options_.superpixels;
                spo.num_threads = std::max(1, n - 1);
                spo.disparity_weight = 0.0f;
                w.superpixels = std::make_shared<const Superpixels>(compute_superpixels(image, spo, DisparityMap()));
            });
    }
    errors.rethrow_if_any();
    return w;
}

InterpolationResult RobustInterpolator::run(const SceneFlowField &matches, const SparseLidar &lidar0,
                                            const cv::Mat &image, const DisparityMap &geometry_hint,
                                            const StereoCamera &camera, const SparseLidar &lidar1,
                                            int threads, const ImageWork *work) const {
    require(threads >= 0 && threads <= 1024, ErrorCode::InvalidArgument, "interpolation: threads must be in [0, 1024]");
    InterpolationOptions this_call = options_;
    if (threads > 0) this_call.num_threads = threads;
    const auto t_start = Clock::now();
    validate_inputs(matches, lidar0, image);
    const int largest = this_call.superpixels.region_size;
    this_call.superpixels.region_size =
        superpixel_size(this_call, this_call.use_lidar ? lidar0.points.size() : 0, image.size());
    this_call.initial_hypotheses = initial_hypotheses(this_call.initial_hypotheses, this_call.superpixels.region_size, largest);
    const InterpolationOptions &o = this_call;
    validate_lidar(lidar1, image.size(), "t1 LiDAR");
    validate_hint(geometry_hint, image.size());
    const int w = image.cols, h = image.rows;
    InterpolationResult res;
    res.superpixel_size = o.superpixels.region_size;
    const auto t_seeds = Clock::now();
    const SeedSet seed_set = prepare_seeds(matches, lidar0, lidar1, geometry_hint, camera, w, h, o, res);
    res.timings.seeds_s = seconds_since(t_seeds);
    if (work && (work->region_size != o.superpixels.region_size || !pixel_identical(work->image, image)))
        work = nullptr;  // another image's, or another size's
    SeedGraph graph;
    const Superpixels sp =
        segment_beside_graph(image, geometry_hint, sed_.get(), seed_set, largest, o, work, res, graph);
    const Neighbourhoods neighbourhoods = find_neighbourhoods(seed_set, sp, std::move(graph), o, res);
    const Models models = fit_models(seed_set, sp, neighbourhoods, o, options_.initial_hypotheses, res);
    write_output(seed_set, sp, neighbourhoods, models, lidar0, w, h, o, res);
    res.timings.total_s = seconds_since(t_start);
    return res;
}

SceneFlowField interpolate_scene_flow(const SceneFlowField &matches, const SparseLidar &lidar0,
                                      const cv::Mat &image, const InterpolationOptions &options) {
    return RobustInterpolator(options).run(matches, lidar0, image).dense;
}

}  // namespace lidarflow::interpolation
