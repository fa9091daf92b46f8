// SPDX-License-Identifier: MIT
#include "consistency/consistency.hpp"

#include <chrono>

#include "consistency/steps.hpp"
#include "consistency/validate.hpp"
#include "core/error.hpp"

namespace lidarflow::consistency {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

long long count_valid(const SceneFlowField &f) { return cv::countNonZero(f.valid); }

// The stages on options checked where they entered (run_consistency).
ConsistencyResult run_checked(const SceneFlowField &forward, const SceneFlowField &backward, const DisparityMap &sgm,
                              const SparseLidar &lidar0, const detail::CheckedOptions &checked) {
    const Clock::time_point start = Clock::now();
    const ConsistencyOptions &opt = checked.get();
    detail::check_field(forward, "forward");
    detail::check_field(backward, "backward");
    const int h = forward.height(), w = forward.width();
    detail::check_size(backward.u, h, w, "backward field");
    detail::check_size(sgm, h, w, "SGM disparity");
    const LidarReference lidar = LidarReference::build(lidar0, w, h, opt.support_window);

    ConsistencyResult r;
    r.sgm = sgm.clone();
    r.lidar_pixels = lidar.is_lidar.clone();
    r.counts.lidar_pixels = lidar.count;

    // Intermediate fields (~10 MB each on KITTI) live only as long as the next step needs them:
    // this stage's high-water mark stays resident in a process that keeps its freed heap.
    Clock::time_point t;
    SceneFlowField after_2a;  // what 2b reads: 2a's output, clustered where after_sgm is kept
    {
        // LiDAR d0 is exact (the matcher may not move it); put it in so that every output carries it.
        SceneFlowField input = forward;
        if (!lidar.image_only()) {
            input.d0 = forward.d0.clone();
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    if (lidar.is_lidar(y, x) && forward.valid(y, x)) input.d0(y, x) = lidar.disparity(y, x);
        }
        r.counts.input = count_valid(input);

        t = Clock::now();
        after_2a = detail::sgm_check(input, sgm, lidar, checked);
        r.seconds.sgm_check = seconds_since(t);
        r.counts.after_sgm_check = count_valid(after_2a);
        input = SceneFlowField();

        if (opt.after_sgm_field) {
            t = Clock::now();
            r.after_sgm = detail::remove_small_clusters(after_2a, lidar, cv::Mat1b(), checked).field;
            r.seconds.sgm_clusters = seconds_since(t);
            r.counts.after_sgm_clusters = count_valid(r.after_sgm);
            after_2a = r.after_sgm;  // shares its planes
        }
    }

    t = Clock::now();
    ForwardBackwardResult fb = detail::forward_backward_check(after_2a, backward, lidar, checked);
    after_2a = SceneFlowField();
    r.seconds.fb_check = seconds_since(t);
    r.counts.after_fb_check = count_valid(fb.field);
    r.counts.lidar_motion_unreliable = cv::countNonZero(fb.lidar_motion_unreliable);

    t = Clock::now();
    r.after_fb = detail::remove_small_clusters(fb.field, lidar, fb.lidar_motion_unreliable, checked).field;
    fb.field = SceneFlowField();
    r.seconds.fb_clusters = seconds_since(t);
    r.counts.after_fb_clusters = count_valid(r.after_fb);

    t = Clock::now();
    r.sparse = detail::sparsify(r.after_fb, fb.error, lidar, checked);
    r.seconds.sparsify = seconds_since(t);
    r.counts.sparse = count_valid(r.sparse);

    r.fb_error = fb.error;
    r.lidar_motion_unreliable = fb.lidar_motion_unreliable;
    r.seconds.total = seconds_since(start);
    return r;
}

}  // namespace

ConsistencyResult run_consistency(const SceneFlowField &forward, const SceneFlowField &backward,
                                  const DisparityMap &sgm, const SparseLidar &lidar0,
                                  const ConsistencyOptions &opt) {
    return run_checked(forward, backward, sgm, lidar0, detail::CheckedOptions(opt));
}

ConsistencyResult run_consistency(const SceneFlowField &forward, const SceneFlowField &backward, const cv::Mat &left0,
                                  const cv::Mat &right0, const SparseLidar &lidar0, const ConsistencyOptions &opt) {
    const Clock::time_point start = Clock::now();
    const detail::CheckedOptions checked(opt);
    detail::check_field(forward, "forward");
    detail::check_size(left0, forward.height(), forward.width(), "left image");
    const DisparityMap sgm = detail::compute_sgm_disparity(left0, right0, checked);
    const double sgm_seconds = seconds_since(start);
    ConsistencyResult r = run_checked(forward, backward, sgm, lidar0, checked);
    r.seconds.sgm = sgm_seconds;
    r.seconds.total = seconds_since(start);
    return r;
}

}  // namespace lidarflow::consistency
