// SPDX-License-Identifier: MIT
#include "matching/decoupled_matcher.hpp"

#include <chrono>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <omp.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "consistency/sgm_check.hpp"
#include "core/error.hpp"
#include "core/gray.hpp"
#include "core/limits.hpp"
#include "core/log.hpp"
#include "core/pixels.hpp"
#include "core/points3d.hpp"
#include "core/rounding.hpp"
#include "core/threads.hpp"
#include "flow/dis.hpp"
#include "lidar/projection.hpp"
#include "matching/motion_prior.hpp"
#include "motion/ego_motion.hpp"
#include "stereo/guided_sgm.hpp"

namespace lidarflow::matching {

cv::Ptr<cv::DISOpticalFlow> flow_search(const FlowSearchOptions &o) {
    cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
    dis->setFinestScale(o.finest_scale);
    dis->setPatchSize(o.patch_size);
    dis->setPatchStride(o.patch_stride);
    dis->setGradientDescentIterations(o.descent_iterations);
    dis->setVariationalRefinementIterations(o.refine_iterations);
    return dis;
}

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }


// Grid pixels with a t0 disparity and where pyramidal Lucas-Kanade finds them at t1.
struct Tracks {
    std::vector<cv::Point2f> from, to;
};

Tracks track_grid(const cv::Mat &g0, const cv::Mat &g1, const DisparityMap &d0, int step) {
    Tracks t, all;
    for (int y = step / 2; y < g0.rows; y += step)
        for (int x = step / 2; x < g0.cols; x += step)
            if (disparity_valid(d0(y, x))) all.from.emplace_back(static_cast<float>(x), static_cast<float>(y));
    if (all.from.size() < 16) return t;
    std::vector<uchar> ok;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(g0, g1, all.from, all.to, ok, err, cv::Size(15, 15), 4);
    for (size_t i = 0; i < all.from.size(); ++i)
        if (ok[i] && std::isfinite(all.to[i].x) && std::isfinite(all.to[i].y)) {
            t.from.push_back(all.from[i]);
            t.to.push_back(all.to[i]);
        }
    return t;
}

// The dominant rigid motion t0 -> t1, fitted to the tracks and the stereo disparities at both
// ends (invalid when they support none), on `threads` threads (the same model on any count).
motion::EgoMotion track_rigid_motion(const Tracks &tr, const DisparityMap &d0, const DisparityMap &d1,
                                            const StereoCamera &camera, uint64_t seed, int threads) {
    std::vector<float> xs, ys, d0s, d1s, us, vs;
    for (size_t i = 0; i < tr.from.size(); ++i) {
        const int tx = static_cast<int>(std::lround(tr.to[i].x)), ty = static_cast<int>(std::lround(tr.to[i].y));
        if (tx < 0 || ty < 0 || tx >= d1.cols || ty >= d1.rows || !disparity_valid(d1(ty, tx))) continue;
        xs.push_back(tr.from[i].x);
        ys.push_back(tr.from[i].y);
        d0s.push_back(d0(static_cast<int>(tr.from[i].y), static_cast<int>(tr.from[i].x)));
        d1s.push_back(d1(ty, tx));
        us.push_back(tr.to[i].x - tr.from[i].x);
        vs.push_back(tr.to[i].y - tr.from[i].y);
    }
    motion::EgoMotionOptions eo;
    eo.seed = static_cast<unsigned>(seed);
    eo.threads = std::max(1, threads);
    return camera.valid() ? motion::fit_rigid_ego_motion(xs, ys, d0s, d1s, us, vs, eo, camera)
                          : motion::fit_ego_motion(xs, ys, d0s, d1s, us, vs, eo);
}

// The camera's motion t0 -> t1 from the tracks and the t0 disparities alone (perspective-n-point
// with RANSAC), before any t1 stereo exists; invalid when too few tracks agree on one motion.
motion::EgoMotion pose_from_t0(const Tracks &tr, const DisparityMap &d0, const StereoCamera &camera) {
    motion::EgoMotion m;
    if (!camera.valid()) return m;
    std::vector<cv::Point3f> object;
    std::vector<cv::Point2f> image;
    for (size_t i = 0; i < tr.from.size(); ++i) {
        const float d = d0(static_cast<int>(tr.from[i].y), static_cast<int>(tr.from[i].x));
        if (!(d > 0.5f)) continue;  // too far to place in depth
        double p[3];
        back_project(camera, tr.from[i].x, tr.from[i].y, d, p);
        object.emplace_back(static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2]));
        image.push_back(tr.to[i]);
    }
    const motion::EgoMotionOptions eo;
    if (static_cast<int>(object.size()) < eo.min_inliers) return m;
    const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    // OpenCV's RANSAC draws from a fixed seed: the pose is deterministic.
    if (!cv::solvePnPRansac(object, image, k, cv::noArray(), rvec, tvec, false, eo.hypotheses, eo.flow_inlier, 0.99,
                            inliers, cv::SOLVEPNP_EPNP) ||
        static_cast<int>(inliers.size()) < std::max(eo.min_inliers, static_cast<int>(eo.min_inlier_share * object.size())))
        return m;
    cv::Matx33d r;
    cv::Rodrigues(rvec, r);
    for (int i = 0; i < 9; ++i) m.R[i] = r.val[i];
    for (int i = 0; i < 3; ++i) m.t[i] = tvec.at<double>(i);
    m.camera = camera;
    m.calibrated = m.valid = true;
    m.inliers = static_cast<int>(inliers.size());
    m.candidates = static_cast<int>(object.size());
    return m;
}

// The t0 points where the motion carries them at t1 (the nearest of several on one pixel);
// points on movers land wrong, which the capped LiDAR term lets the images outvote.
SparseLidar carry_points(const SparseLidar &lidar0, const motion::EgoMotion &m, int threads) {
    SparseLidar carried{lidar0.width, lidar0.height, {}};
    const int n = static_cast<int>(lidar0.points.size());
    // Predicted in parallel, kept in the points' order (x < 0: the point leaves the image).
    std::vector<LidarPoint> moved(lidar0.points.size());
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int i = 0; i < n; ++i) {
        const LidarPoint &p = lidar0.points[static_cast<size_t>(i)];
        float d1 = 0, u = 0, v = 0;
        int x = 0, y = 0;
        moved[static_cast<size_t>(i)] =
            m.predict(static_cast<float>(p.x), static_cast<float>(p.y), p.disparity, d1, u, v) && d1 > 0 &&
                    d1 <= kMaxLidarDisparity &&
                    lidar::nearest_pixel(p.x + u, p.y + v, {carried.width, carried.height}, x, y)
                ? LidarPoint{x, y, d1}
                : LidarPoint{-1, -1, 0.0f};
    }
    for (const LidarPoint &p : moved)
        if (p.x >= 0) carried.points.push_back(p);
    return SparseLidar::from_map(carried.to_map());
}

// The flow of motion `m` at every pixel, with the disparity filled along the row where stereo
// has none; empty when m is invalid. DIS resamples it down its pyramid, so it is predicted on a
// 2 px grid and resized (a 4 px grid cost 0.2 points).
cv::Mat2f rigid_flow(const motion::EgoMotion &m, const DisparityMap &d, int threads) {
    if (!m.valid) return {};
    constexpr int kStep = 2;
    cv::Mat2f coarse((d.rows + kStep - 1) / kStep, (d.cols + kStep - 1) / kStep);
    // Per thread, one coarse row's grid columns with a disparity (x, y, d) and their prediction
    // (EgoMotion::predict_many), allocated before the region.
    const int T = std::max(1, threads), n = coarse.cols;
    std::vector<std::vector<float>> rows(static_cast<size_t>(T), std::vector<float>(6 * static_cast<size_t>(n)));
#pragma omp parallel for schedule(static) num_threads(T)
    for (int cy = 0; cy < coarse.rows; ++cy) {
        const int y = cy * kStep;
        float *xs = rows[static_cast<size_t>(omp_get_thread_num())].data(), *ys = xs + n, *ds = ys + n, *d1 = ds + n,
              *us = d1 + n, *vs = us + n;
        int k = 0;  // grid columns with a disparity so far
        float last = -1.0f;
        cv::Vec2f *out = coarse[cy];
        for (int x = 0; x < d.cols; ++x) {
            if (disparity_valid(d(y, x))) last = d(y, x);
            if (x % kStep) continue;
            out[x / kStep] = cv::Vec2f(0.0f, 0.0f);
            if (last < 0) continue;
            xs[k] = static_cast<float>(x), ys[k] = static_cast<float>(y), ds[k] = last;
            ++k;
        }
        m.predict_many(xs, ys, ds, k, d1, us, vs);
        for (int j = 0; j < k; ++j)
            out[static_cast<int>(xs[j]) / kStep] =
                cv::Vec2f(std::isfinite(us[j]) ? us[j] : 0.0f, std::isfinite(vs[j]) ? vs[j] : 0.0f);
    }
    cv::Mat2f prior;
    cv::resize(coarse, prior, d.size(), 0, 0, cv::INTER_LINEAR);
    return prior;
}

// Sum of |from - to warped back by flow| over (2r + 1)^2 boxes (a target outside `to` reads 0:
// an error of `from` itself). `from`, `to`: 8-bit gray.
cv::Mat1f warp_error(const cv::Mat &from, const cv::Mat &to, const cv::Mat2f &flow, int r, int threads) {
    cv::Mat2f map(flow.size());
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < flow.rows; ++y)
        for (int x = 0; x < flow.cols; ++x) map(y, x) = flow(y, x) + cv::Vec2f(static_cast<float>(x), static_cast<float>(y));
    cv::Mat warped, diff;
    cv::remap(to, warped, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::absdiff(from, warped, diff);
    cv::Mat1f e;
    cv::boxFilter(diff, e, CV_32F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false);
    return e;
}

// DIS's flow, or the rigid prior where that explains the images better and rests on a measured
// disparity (the static scene's exact motion from its depth; DIS drifts on weak texture).
cv::Mat2f choose_rigid(const cv::Mat &from, const cv::Mat &to, cv::Mat2f dis, const cv::Mat2f &rigid,
                       const DisparityMap &d, int r, int threads) {
    if (r <= 0 || rigid.empty()) return dis;
    const cv::Mat1f ed = warp_error(from, to, dis, r, threads), er = warp_error(from, to, rigid, r, threads);
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < dis.rows; ++y)
        for (int x = 0; x < dis.cols; ++x)
            if (disparity_valid(d(y, x)) && er(y, x) < ed(y, x)) dis(y, x) = rigid(y, x);
    return dis;
}

// The size a frame of `size` is searched at: itself, or padded where OpenCV's DIS refuses images
// under 12 px a side (and patches wider than the image) and where ours (`own`) has no pyramid
// level at finest_scale.
cv::Size search_size(cv::Size size, const FlowSearchOptions &o, bool own) {
    const int side = std::max(16, 2 * o.patch_size);
    cv::Size s(std::max(size.width, side), std::max(size.height, side));
    while (own && flow::dis_coarsest_scale(s, o.patch_size) < o.finest_scale) s = {2 * s.width, 2 * s.height};
    return s;
}

// The flow from `from` to `to` at o's settings, started from `initial` (empty: from zero). The
// project's own dense inverse search (flow/dis.hpp: OpenCV's flow bit for bit, in less time)
// unless o asks for variational refinement, which only OpenCV's has.
// `pyramids`: both images prepared (prepared_for_search), or null.
cv::Mat2f dense_inverse_search(const cv::Mat &from, const cv::Mat &to, const FlowSearchOptions &o, int threads,
                               cv::Mat2f initial = cv::Mat2f(),
                               const std::pair<const flow::DisPyramid *, const flow::DisPyramid *> &pyramids = {}) {
    const bool own = o.refine_iterations == 0;
    const flow::DisOptions d{o.finest_scale, o.patch_size, o.patch_stride, o.descent_iterations, std::max(1, threads)};
    if (own && pyramids.first && pyramids.second) return flow::dis_flow(*pyramids.first, *pyramids.second, d, initial);
    cv::Ptr<cv::DISOpticalFlow> dis;
    if (!own) {
        dis = flow_search(o);
        release_openmp_workers();  // OpenCV's DIS runs on OpenCV's threads: ours must not spin beside them
    }
    auto calc = [&](const cv::Mat &a, const cv::Mat &b, cv::Mat2f &flow) {
        if (own)
            flow = flow::dis_flow(a, b, d, flow);
        else
            dis->calc(a, b, flow);
    };
    // A small frame is searched inside a replicated border and cropped back.
    const cv::Size padded = search_size(from.size(), o, own);
    const int px = padded.width - from.cols, py = padded.height - from.rows;
    if (px == 0 && py == 0) {
        cv::Mat2f flow = std::move(initial);  // the search starts from a given flow of the right size
        calc(from, to, flow);
        return flow;
    }
    cv::Mat a, b;
    cv::Mat2f flow;
    cv::copyMakeBorder(from, a, 0, py, 0, px, cv::BORDER_REPLICATE);
    cv::copyMakeBorder(to, b, 0, py, 0, px, cv::BORDER_REPLICATE);
    if (!initial.empty()) cv::copyMakeBorder(initial, flow, 0, py, 0, px, cv::BORDER_REPLICATE);
    calc(a, b, flow);
    return flow(cv::Rect(0, 0, from.cols, from.rows)).clone();
}

// A gray image prepared for our flow search at o's settings; null where the search pads it or
// OpenCV's runs (dense_inverse_search).
std::shared_ptr<const flow::DisPyramid> prepared_for_search(const cv::Mat &gray, const FlowSearchOptions &o) {
    if (o.refine_iterations != 0 || search_size(gray.size(), o, true) != gray.size()) return nullptr;
    return std::make_shared<const flow::DisPyramid>(gray, o.finest_scale, o.patch_size);
}

// The points that guide the stereo of a pair: `lidar` when the stereo is guided and the LiDAR
// on, else none (of lidar's size).
SparseLidar stereo_guide(const SparseLidar &lidar, const MatchingOptions &opt) {
    return opt.guided_stereo && opt.use_lidar ? lidar : SparseLidar{lidar.width, lidar.height, {}};
}

// One direction's 4-vectors: d0 from the reference pair's disparity (the LiDAR measurement where
// there is one), (u, v) from the flow, d1 from the other pair's disparity at the flow target.
SceneFlowField assemble(const cv::Mat2f &flow, const DisparityMap &ref, const DisparityMap &target,
                        const SparseLidar &lidar, int threads) {
    const int h = flow.rows, w = flow.cols;
    SceneFlowField f = SceneFlowField::uninitialized(w, h);  // each row cleared where it is filled
    const DisparityMap measured = lidar.points.empty() ? DisparityMap() : lidar.to_map();
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads))
    for (int y = 0; y < h; ++y) {
        f.clear_row(y);
        const float *mr = measured.empty() ? nullptr : measured[y];
        for (int x = 0; x < w; ++x) {
            const cv::Vec2f m = flow(y, x);
            const float d = mr && mr[x] >= 0.0f ? mr[x] : ref(y, x);  // the LiDAR's measurement where there is one
            if (!std::isfinite(m[0]) || !std::isfinite(m[1]) || !disparity_valid(d)) continue;
            int tx, ty;
            if (!nearest_inside(x + m[0], y + m[1], w, h, tx, ty) || !disparity_valid(target(ty, tx))) continue;
            f.u(y, x) = m[0];
            f.v(y, x) = m[1];
            f.d0(y, x) = d;
            f.d1(y, x) = target(ty, tx);
            f.valid(y, x) = 1;
            f.confidence(y, x) = 1.0f;
        }
    }
    return f;
}

// Two pairs' time steps agree within 25 % (either unknown: assumed to).
bool similar_steps(int64_t a, int64_t b) {
    if (a <= 0 || b <= 0) return true;
    const double r = static_cast<double>(a) / static_cast<double>(b);
    return r >= 0.8 && r <= 1.25;
}

// One stereo pair's disparity, with `guide` its guiding points (stereo_guide).
DisparityMap pair_disparity(const cv::Mat &l, const cv::Mat &r, const SparseLidar &guide, const MatchingOptions &opt,
                            const consistency::SgmOptions &sgm) {
    if (!opt.guided_stereo) return consistency::compute_sgm_disparity(l, r, sgm);
    stereo::GuidedSgmOptions g = opt.stereo;
    g.num_disparities = sgm.num_disparities;
    g.threads = opt.threads;
    return stereo::guided_sgm(l, r, guide, g);
}

}  // namespace

std::shared_ptr<DecoupledStereo> first_frame_stereo(const cv::Mat &left, const cv::Mat &right,
                                                    const SparseLidar &lidar, const MatchingOptions &opt,
                                                    const consistency::SgmOptions &sgm) {
    opt.validate();
    require(!left.empty() && left.size() == right.size(), ErrorCode::SizeMismatch,
            "decoupled matcher: a frame's two images must be non-empty and of one size");
    auto s = std::make_shared<DecoupledStereo>();
    s->lidar = stereo_guide(lidar, opt);
    s->disparity = pair_disparity(left, right, s->lidar, opt, sgm);
    s->left = left.clone();
    s->right = right.clone();
    s->pyramid = prepared_for_search(gray8(left), opt.flow);
    return s;
}

bool DecoupledStereo::matches(const cv::Mat &l, const cv::Mat &r, const SparseLidar &guide) const {
    return !disparity.empty() && pixel_identical(left, l) && pixel_identical(right, r) && lidar.points == guide.points;
}


DecoupledResult match_decoupled(const MatchInput &in, const MatchingOptions &opt, const consistency::SgmOptions &sgm,
                                const StereoCamera &camera, bool backward, const DecoupledStereo *t0_reuse,
                                int64_t step_us, const DecoupledStereo *lagged_prior) {
    opt.validate();
    require(!in.left0.empty() && in.left0.size() == in.right0.size() && in.left0.size() == in.left1.size() &&
                in.left0.size() == in.right1.size(),
            ErrorCode::SizeMismatch, "decoupled matcher: the four images must be non-empty and of one size");
    DecoupledResult r;
    auto t = Clock::now();
    const SparseLidar guide0 = stereo_guide(in.lidar0, opt), guide1 = stereo_guide(in.lidar1, opt);
    auto disparity = [&](const cv::Mat &l, const cv::Mat &rt, const SparseLidar &guide) {
        return pair_disparity(l, rt, guide, opt, sgm);
    };
    r.reused_t0 = t0_reuse && t0_reuse->matches(in.left0, in.right0, guide0);
    r.sgm0 = r.reused_t0 ? t0_reuse->disparity : disparity(in.left0, in.right0, guide0);
    r.seconds_stereo = seconds_since(t);

    t = Clock::now();
    release_openmp_workers();  // the tracks run on OpenCV's threads
    const cv::Mat g0 = gray8(in.left0), g1 = gray8(in.left1);
    const Tracks tracks = opt.flow.prior_track_step > 0 ? track_grid(g0, g1, r.sgm0, opt.flow.prior_track_step) : Tracks{};
    const double seconds_tracks = seconds_since(t);

    t = Clock::now();
    r.guide1 = guide1;
    if (opt.carry_lidar && guide1.points.empty() && !guide0.points.empty()) {
        const motion::EgoMotion pose = pose_from_t0(tracks, r.sgm0, camera);
        if (pose.valid) r.guide1 = carry_points(guide0, pose, opt.threads);
    }
    r.sgm1 = disparity(in.left1, in.right1, r.guide1);
    r.seconds_stereo += seconds_since(t);

    t = Clock::now();
    motion::EgoMotion motion;
    if (opt.flow.prior_track_step > 0) motion = track_rigid_motion(tracks, r.sgm0, r.sgm1, camera, opt.random_seed, opt.threads);
    r.tracked_motion = motion.valid;
    if (opt.flow.prior_track_step > 0 && !motion.valid)
        log::write(log::Level::Warning, "decoupled matching: no rigid background motion fits the tracks; dense "
                                        "inverse search starts from zero flow (image-only prior)");
    const SparseLidar none{in.left0.cols, in.left0.rows, {}};
    const int rc = opt.flow.rigid_choice_radius;
    // A stream's movers keep their motion: it joins the background's in the prior, and so in
    // DIS's start and in the per-pixel choice.
    r.stream_continues = r.reused_t0 && similar_steps(t0_reuse->step_us, step_us) && motion.valid && motion.calibrated;
    const DecoupledStereo *source = lagged_prior ? lagged_prior : r.reused_t0 ? t0_reuse : nullptr;
    const bool same_step = source && similar_steps(source->step_us, step_us);
    const bool prior = opt.stream_prior && source && motion.calibrated && !source->object_motion.empty();
    if (prior && !same_step)
        log::write(log::Level::Info, "no motion prior for this pair: it spans " + std::to_string(step_us) +
                                         " us, the pair that made it " + std::to_string(source->step_us) +
                                         " us (a dropped frame?)");
    const cv::Mat3f objects = prior && same_step ? source->object_motion : cv::Mat3f();
    cv::Mat2f prior0 = rigid_flow(motion, r.sgm0, opt.threads);
    add_object_motion(motion, r.sgm0, objects, prior0, opt.threads);
    // Each image is prepared for the flow search once: both directions read it, and a stream's
    // t0 image is the previous pair's t1.
    const bool same_settings = r.reused_t0 && t0_reuse->pyramid && t0_reuse->pyramid->size() == g0.size() &&
                               t0_reuse->pyramid->finest_scale() == opt.flow.finest_scale &&
                               t0_reuse->pyramid->patch_size() == opt.flow.patch_size;
    const std::shared_ptr<const flow::DisPyramid> pyr0 =
        same_settings ? t0_reuse->pyramid : prepared_for_search(g0, opt.flow);
    r.pyramid1 = prepared_for_search(g1, opt.flow);
    const cv::Mat2f flow0 = choose_rigid(
        g0, g1, dense_inverse_search(g0, g1, opt.flow, opt.threads, prior0.clone(), {pyr0.get(), r.pyramid1.get()}),
        prior0, r.sgm0, rc, opt.threads);
    r.forward = assemble(flow0, r.sgm0, r.sgm1, opt.use_lidar ? in.lidar0 : none, opt.threads);
    if (backward) {
        const motion::EgoMotion back = motion.valid ? motion.inverse() : motion;
        cv::Mat2f prior1 = rigid_flow(back, r.sgm1, opt.threads);
        add_object_motion(back, r.sgm1, reverse_object_motion(objects, flow0, motion, opt.threads), prior1,
                          opt.threads);
        r.backward = assemble(choose_rigid(g1, g0,
                                           dense_inverse_search(g1, g0, opt.flow.backward(), opt.threads,
                                                                prior1.clone(), {r.pyramid1.get(), pyr0.get()}),
                                           prior1, r.sgm1, rc, opt.threads),
                              r.sgm1, r.sgm0, opt.use_lidar ? in.lidar1 : none, opt.threads);
    }
    r.seconds_flow = seconds_tracks + seconds_since(t);
    return r;
}

}  // namespace lidarflow::matching
