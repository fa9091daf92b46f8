// SPDX-License-Identifier: MIT
// The header-only C++ API (include/lidarflow/lidarflow.hpp) against the shared library, seeing
// only the public headers: errors (status and message), options by key and presets, a run on
// the synthetic scene of the C suites (copies, views, 3-D, the C ABI's own copy), NaN holes of a
// sparse stage, and, with OpenCV, cv::Mat in (gray, BGR, any stride) and out. Built twice: with
// OpenCV (test_cpp_api) and with LIDARFLOW_USE_OPENCV=0 (test_cpp_api_no_opencv).
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "capi_scene.h"
#include "lidarflow/lidarflow.hpp"

// cmocka last: its fail() macro must not meet the standard library's or OpenCV's headers.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
// cmocka 1.1 has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

namespace lf = lidarflow;

namespace {

constexpr int W = 160, H = 64, D = 10, TU = 3, TV = 1;

// Runs `call`, which must throw lf::Error with `status` and a message containing `needle`.
template <typename F>
void expect_error(F &&call, int32_t status, const char *needle, const char *what) {
    try {
        call();
    } catch (const lf::Error &e) {
        if (e.status() != status) fail_msg("%s: status %d (%s), expected %d", what, e.status(), e.what(), status);
        if (std::strstr(e.what(), needle) == nullptr) fail_msg("%s: message '%s' lacks '%s'", what, e.what(), needle);
        assert_string_equal(e.status_string(), lf_status_string(status));
        const std::runtime_error &base = e;  // catchable as the standard type
        assert_string_equal(base.what(), e.what());
        return;
    }
    fail_msg("%s: no lidarflow::Error thrown", what);
}

struct Scene {
    scene_t s{};
    std::vector<float> lidar;  // (x, y, d) triples
    Scene() {
        if (!scene_make(&s, W, H, D, TU, TV, 7)) fail_msg("out of memory");
        lidar.resize(3 * static_cast<std::size_t>((W / 16 + 1) * (H / 16 + 1)));
        lidar.resize(3 * scene_lidar(&s, 16, lidar.data()));
    }
    ~Scene() { scene_free(&s); }
    Scene(const Scene &) = delete;
    Scene &operator=(const Scene &) = delete;
    lf::Calibration calibration() const { return lf::Calibration::from_c(scene_calibration(&s)); }
    lf::ImageView image(const uint8_t *p) const { return lf::ImageView::gray8(p, W, H); }
};

// The options of the C suites' quick runs (capi_scene.h), optionally stopping at `stage`.
lf::Options scene_options(const char *stage = nullptr) {
    lf::Options o;
    o.set("matching.min_coarsest_height", 16).set("threads", 2);
    if (stage != nullptr) o.set("last_stage", stage);
    return o;
}

void push_pair(lf::Estimator &e, const Scene &sc) {
    const lf::LidarView lidar = lf::LidarView::from_vector(lf::LidarKind::disparity, sc.lidar);
    e.push(0, sc.image(sc.s.left0), sc.image(sc.s.right0), lidar);
    e.push(100000, sc.image(sc.s.left1), sc.image(sc.s.right1), lidar);
}

bool same_bits(const std::vector<float> &a, const std::vector<float> &b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// set_log_handler from inside a handler would destroy the running handler: it is refused
// (LF_ERR_BAD_STATE) and the handler stays; outside a handler it works.
void test_log_handler_not_from_a_handler(void **) {
    Scene sc;
    int calls = 0, refused = 0;
    lf::set_log_handler(
        [&](int, const std::string &) {
            ++calls;
            try {
                lf::set_log_handler({});
            } catch (const lf::Error &e) {
                refused += e.status() == LF_ERR_BAD_STATE;
            }
        },
        LF_LOG_DEBUG);
    std::vector<float> lidar = sc.lidar;
    lidar.insert(lidar.end(), {-5.0f, 3.0f, 4.0f});  // off the image: dropped and logged
    lf::Estimator e(sc.calibration(), scene_options("matching"));
    e.push(0, sc.image(sc.s.left0), sc.image(sc.s.right0), lf::LidarView::from_vector(lf::LidarKind::disparity, lidar));
    e.push(1, sc.image(sc.s.left1), sc.image(sc.s.right1), lf::LidarView::from_vector(lf::LidarKind::disparity, lidar));
    lf::set_log_handler({});
    assert_true(calls >= 2);
    assert_int_equal(refused, calls);
}

// frames_in_flight 2: the pair comes one push late, or from flush(), equal to the pair alone.
void test_frames_in_flight(void **) {
    Scene sc;
    lf::Estimator alone(sc.calibration(), scene_options());
    assert_false(alone.flush());  // one pair at a time: nothing is ever in flight
    push_pair(alone, sc);
    const lf::Result single = alone.result();
    lf::Options o = scene_options();
    o.set("frames_in_flight", 2);
    lf::Estimator e(sc.calibration(), o);
    push_pair(e, sc);
    assert_false(e.has_result());
    assert_true(e.flush());
    assert_true(e.has_result());
    assert_false(e.flush());
    const lf::Result r = e.result();
    assert_int_equal(r.info.t1_us, 100000);
    assert_true(same_bits(r.u, single.u) && same_bits(r.v, single.v) && same_bits(r.d0, single.d0) &&
                same_bits(r.d1, single.d1));
}

// The C++ layer refuses what C would silently misread: a key or value with an embedded NUL,
// and (with OpenCV) a 3 x N Mat of points; a rigid lidar_to_camera is checked by the C ABI.
void test_cpp_checks(void **) {
    lf::Options o;
    expect_error([&] { o.set(std::string("threads\0x", 9), 2); }, LF_ERR_INVALID_ARGUMENT, "NUL", "NUL key");
    expect_error([&] { o.set("preset", std::string("fast\0", 5)); }, LF_ERR_INVALID_ARGUMENT, "NUL", "NUL value");
    o.set("threads", 2);
    Scene sc;
    lf::Calibration scaled = sc.calibration();
    scaled.has_lidar_to_camera = true;
    scaled.lidar_to_camera = {1000, 0, 0, 0, 0, 1000, 0, 0, 0, 0, 1000, 0, 0, 0, 0, 1};
    expect_error([&] { lf::Estimator e(scaled, o); }, LF_ERR_INVALID_ARGUMENT, "not a rotation matrix", "scaled");
#if LIDARFLOW_USE_OPENCV
    const cv::Mat transposed(3, 50, CV_32FC1, cv::Scalar(1.0f));
    expect_error([&] { lf::LidarView::from_mat(lf::LidarKind::points_camera, transposed); }, LF_ERR_INVALID_ARGUMENT,
                 "one per row", "3 x N");
    const cv::Mat records(50, 4, CV_32FC1, cv::Scalar(1.0f));
    assert_int_equal(lf::LidarView::from_mat(lf::LidarKind::points_camera, records).count, 50);
#endif
}

void test_version(void **) {
    assert_string_equal(lf::version_string().c_str(), LF_VERSION_STRING);
    assert_int_equal(lf::version_number(), LF_VERSION_NUMBER);
    assert_int_equal(lf::abi_major(), LF_ABI_MAJOR);
    assert_string_equal(lf::status_string(LF_ERR_NOT_READY), lf_status_string(LF_ERR_NOT_READY));
}

// The default "threads": the CPUs this process may run on, at most 256.
int usable_cpus() {
    cpu_set_t set;
    CPU_ZERO(&set);
    assert_int_equal(sched_getaffinity(0, sizeof set, &set), 0);
    return std::min(CPU_COUNT(&set), 256);
}

void test_options(void **) {
    lf::Options o;
    assert_int_equal(o.get_int("threads"), usable_cpus());
    o.set("threads", 3).set("interpolation.distance_sigma", 12.5).set("use_lidar", false);
    assert_int_equal(o.get_int("threads"), 3);
    assert_true(o.get_float("interpolation.distance_sigma") == 12.5);
    assert_int_equal(o.get_int("use_lidar"), 0);
    o.set("interpolation.distance_sigma", 20);  // an integer sets a float key
    assert_true(o.get_float("interpolation.distance_sigma") == 20.0);
    o.set("matching.max_flow", 300.0f).set("matching.grid_step", std::size_t{4}).set("use_lidar", 1L);
    assert_true(o.get_float("matching.max_flow") == 300.0);
    assert_int_equal(o.get_int("matching.grid_step"), 4);
    assert_int_equal(o.get_int("use_lidar"), 1);
    o.set("last_stage", "sparse");
    assert_string_equal(o.get_string("last_stage").c_str(), "sparse");
    o.set("last_stage", std::string("matching"));
    assert_string_equal(o.get_string("last_stage").c_str(), "matching");
    o.set("last_stage", std::string_view("consistency"));
    assert_string_equal(o.get_string("last_stage").c_str(), "consistency");
    expect_error([&] { o.set("last_stage", static_cast<const char *>(nullptr)); }, LF_ERR_INVALID_ARGUMENT,
                 "last_stage", "null string");
    assert_string_equal(o.get_string("last_stage").c_str(), "consistency");
    o.set_int("matching.iterations", 5).set_float("processing_scale", 0.5).set_string("interpolation.sed_model", "");
    assert_int_equal(o.get_int("matching.iterations"), 5);
    assert_true(o.get_float("processing_scale") == 0.5);

    // Presets: "fast" changes the stage keys and keeps "threads"; a later preset resets them.
    o.set("preset", "fast");
    assert_int_equal(o.get_int("threads"), 3);
    assert_string_equal(o.get_string("matching.method").c_str(), "decoupled");
    assert_true(o.get_float("processing_scale") == 0.65);
    assert_int_equal(o.get_int("matching.flow_patch_size"), 6);
    lf::Options fast = lf::Options::preset("fast");
    assert_int_equal(fast.get_int("matching.flow_patch_stride"), 3);
    assert_int_equal(lf::Options::preset("default").get_int("matching.flow_patch_stride"), 2);
    assert_int_equal(fast.get_int("threads"), usable_cpus());
    lf::Options balanced = lf::Options::preset("balanced");
    assert_int_equal(balanced.get_int("matching.thin_from_level"), 1);
    assert_int_equal(balanced.get_int("matching.backward_grid_step"), 6);
    assert_string_equal(balanced.get_string("preset").c_str(), "balanced");
    lf::Options defaults;
    o.set("preset", "default");
    assert_int_equal(o.get_int("matching.grid_step"), defaults.get_int("matching.grid_step"));

    // Errors carry the status and the C ABI's message; the options stay unchanged.
    expect_error([&] { o.set("no.such_key", 1); }, LF_ERR_INVALID_ARGUMENT, "no.such_key", "unknown key");
    expect_error([&] { o.set("threads", 0); }, LF_ERR_INVALID_ARGUMENT, "threads", "out of range");
    assert_int_equal(o.get_int("threads"), 3);
    expect_error([&] { o.set("threads", "four"); }, LF_ERR_INVALID_ARGUMENT, "threads", "string for an int");
    expect_error([&] { o.set("matching.max_flow", std::nan("")); }, LF_ERR_INVALID_ARGUMENT, "max_flow", "NaN");
    expect_error([&] { o.set("threads", UINT64_MAX); }, LF_ERR_INVALID_ARGUMENT, "threads", "huge unsigned");
    expect_error([&] { o.get_int("last_stage"); }, LF_ERR_INVALID_ARGUMENT, "last_stage", "int of a string key");
    expect_error([] { lf::Options::preset("fastest"); }, LF_ERR_INVALID_ARGUMENT, "fastest", "unknown preset");
    assert_int_equal(o.get_int("threads"), 3);

    // Moves hand the handle over; a moved-from object throws and is safe to destroy.
    lf::Options moved(std::move(o));
    assert_int_equal(moved.get_int("threads"), 3);
    assert_null(o.get());  // NOLINT(bugprone-use-after-move): testing the moved-from state
    expect_error([&] { o.set("threads", 2); }, LF_ERR_INVALID_ARGUMENT, "", "moved-from options");
    o = std::move(moved);
    assert_int_equal(o.get_int("threads"), 3);
    lf_options_t *raw = o.release();
    assert_non_null(raw);
    assert_null(o.get());
    lf_options_destroy(raw);
}

void test_errors(void **) {
    Scene sc;
    // Creation: a calibration outside lidarflow.h's ranges.
    lf::Calibration bad = sc.calibration();
    bad.fx = 0;
    expect_error([&] { lf::Estimator e(bad); }, LF_ERR_INVALID_ARGUMENT, "fx", "fx = 0");
    lf::Options inconsistent;
    inconsistent.set("matching.support_windows", 0).set("matching.const1", 1);
    expect_error([&] { lf::Estimator e(sc.calibration(), inconsistent); }, LF_ERR_INVALID_ARGUMENT, "const1",
                 "const1 without support windows");
    expect_error([] { lf::Calibration::read_kitti("/nonexistent/calib_cam_to_cam.txt"); }, LF_ERR_IO,
                 "/nonexistent/calib_cam_to_cam.txt", "missing calibration");
    expect_error([] { lf::Calibration::read("/nonexistent/left.yaml,/nonexistent/right.yaml"); }, LF_ERR_IO,
                 "/nonexistent/left.yaml", "missing camera_info");
    // The image size and the raw rig survive the C struct; another size is refused when strict.
    lf::Calibration sized = sc.calibration();
    sized.image_width = W + 8;
    sized.image_height = H;
    sized.raw_left.K[0] = 5;
    const lf::Calibration back = lf::Calibration::from_c(sized.to_c());
    assert_true(back.image_width == W + 8 && back.image_height == H && back.raw_left.K[0] == 5 && !back.rectify);
    lf::Options strict = scene_options("matching");
    strict.set("input.strict", 1);
    lf::Estimator refusing(sized, strict);
    expect_error([&] { refusing.push(0, sc.image(sc.s.left0), sc.image(sc.s.right0)); }, LF_ERR_SIZE_MISMATCH,
                 "calibration is for", "size other than the calibration's");

    lf::Estimator e(sc.calibration(), scene_options("matching"));
    assert_false(e.has_result());
    expect_error([&] { e.result(); }, LF_ERR_NOT_READY, "", "result before a push");
    expect_error([&] { e.info(); }, LF_ERR_NOT_READY, "", "info before a push");
    expect_error([&] { e.points3d(); }, LF_ERR_NOT_READY, "", "points3d before a push");
    expect_error([&] { e.ego_motion(); }, LF_ERR_NOT_READY, "", "ego_motion before a push");
    expect_error([&] { e.object_motion(); }, LF_ERR_NOT_READY, "", "object_motion before a push");
    expect_error([&] { e.views(); }, LF_ERR_NOT_READY, "", "views before a push");
    // Sizes that disagree, timestamps that do not increase, LiDAR the calibration cannot place.
    expect_error([&] { e.push(0, sc.image(sc.s.left0), lf::ImageView::gray8(sc.s.right0, W - 1, H)); },
                 LF_ERR_SIZE_MISMATCH, "", "left/right sizes");
    expect_error([&] { e.push(0, lf::ImageView::gray8(sc.s.left0, W, H, W - 1), sc.image(sc.s.right0)); },
                 LF_ERR_SIZE_MISMATCH, "stride", "stride below a row");
    const float point[3] = {1.0f, 0.5f, 10.0f};
    expect_error([&] { e.push(0, sc.image(sc.s.left0), sc.image(sc.s.right0), lf::LidarView::points_lidar(point, 1)); },
                 LF_ERR_INVALID_ARGUMENT, "lidar_to_camera", "points_lidar without extrinsics");
    expect_error([] { lf::LidarView::from_vector(lf::LidarKind::disparity, std::vector<float>(4)); },
                 LF_ERR_SIZE_MISMATCH, "multiple of 3", "LiDAR vector size");
    e.push(1000, sc.image(sc.s.left0), sc.image(sc.s.right0));
    expect_error([&] { e.push(1000, sc.image(sc.s.left1), sc.image(sc.s.right1)); }, LF_ERR_INVALID_ARGUMENT,
                 "timestamp", "timestamp not increasing");
    const lf::ImageView half_l = lf::ImageView::gray8(sc.s.left1, W / 2, H, W),
                        half_r = lf::ImageView::gray8(sc.s.right1, W / 2, H, W);
    expect_error([&] { e.push(2000, half_l, half_r); },
                 LF_ERR_SIZE_MISMATCH, "", "size differs from the previous frame");
    assert_false(e.has_result());  // failed pushes changed nothing: still one frame
    e.push(2000, sc.image(sc.s.left1), sc.image(sc.s.right1));
    assert_true(e.has_result());
    e.reset();
    assert_false(e.has_result());
    expect_error([&] { e.result(); }, LF_ERR_NOT_READY, "", "result after reset");

    // A moved-from estimator throws, reports no result, and is safe to destroy or reassign.
    lf::Estimator moved(std::move(e));
    assert_null(e.get());  // NOLINT(bugprone-use-after-move)
    assert_false(e.has_result());
    expect_error([&] { e.push(0, sc.image(sc.s.left0), sc.image(sc.s.right0)); }, LF_ERR_INVALID_ARGUMENT, "",
                 "push on a moved-from estimator");
    lf::Options moved_from;
    lf::Options taker(std::move(moved_from));
    expect_error([&] { lf::Estimator x(sc.calibration(), moved_from); }, LF_ERR_INVALID_ARGUMENT, "moved-from",
                 "moved-from options");
    e = std::move(moved);
    assert_non_null(e.get());

#if LIDARFLOW_USE_OPENCV
    const cv::Mat gray16(H, W, CV_16UC1, cv::Scalar(0)), bgra(H, W, CV_8UC4, cv::Scalar(0));
    expect_error([&] { e.push(0, gray16, gray16); }, LF_ERR_INVALID_ARGUMENT, "CV_16UC1", "16-bit image");
    expect_error([&] { e.push(0, bgra, bgra); }, LF_ERR_INVALID_ARGUMENT, "CV_8UC4", "4-channel image");
    expect_error([&] { e.push(0, cv::Mat(), cv::Mat()); }, LF_ERR_INVALID_ARGUMENT, "non-empty", "empty image");
    expect_error([] { lf::LidarView::from_mat(lf::LidarKind::disparity, cv::Mat(5, 2, CV_32FC1)); },
                 LF_ERR_INVALID_ARGUMENT, "columns", "2-column LiDAR Mat");
    expect_error([] { lf::LidarView::from_mat(lf::LidarKind::disparity, cv::Mat(5, 3, CV_64FC1)); },
                 LF_ERR_INVALID_ARGUMENT, "CV_64FC1", "double LiDAR Mat");
    lf::Result partial;
    partial.info.width = W;
    partial.info.height = H;
    expect_error([&] { partial.flow_mat(); }, LF_ERR_INVALID_ARGUMENT, "u and v", "flow of a result without u, v");
#endif
}

void test_dense_run(void **) {
    Scene sc;
    lf::Estimator e(sc.calibration(), scene_options());
    push_pair(e, sc);
    assert_true(e.has_result());

    const lf::ResultInfo info = e.info();
    assert_int_equal(info.width, W);
    assert_int_equal(info.height, H);
    assert_true(info.last_stage == lf::Stage::interpolation);
    assert_int_equal(info.t0_us, 0);
    assert_int_equal(info.t1_us, 100000);
    assert_true(info.total_seconds > 0);
    assert_true(!info.timings.empty());
    for (const lf::Timing &t : info.timings) {
        assert_true(!t.name.empty());
        assert_true(t.seconds >= 0);
    }

    // The copies equal the C ABI's own copy bit for bit (dense: valid everywhere, no NaN).
    const lf::Result r = e.result();
    scene_result_t c;
    assert_int_equal(scene_result_fetch(e.get(), &c), LF_OK);
    const std::size_t n = std::size_t{W} * H;
    assert_int_equal(r.u.size(), n);
    assert_int_equal(r.valid.size(), n);
    assert_memory_equal(r.u.data(), c.u, n * 4);
    assert_memory_equal(r.v.data(), c.v, n * 4);
    assert_memory_equal(r.d0.data(), c.d0, n * 4);
    assert_memory_equal(r.d1.data(), c.d1, n * 4);
    assert_memory_equal(r.confidence.data(), c.confidence, n * 4);
    assert_memory_equal(r.valid.data(), c.valid, n);
    assert_true(scene_result_accuracy(&c, TU, TV, D) > 0.9);
    scene_result_free(&c);
    std::size_t good = 0;
    for (std::size_t i = 0; i < n; ++i) {
        assert_int_equal(r.valid[i], 1);
        good += std::fabs(r.u[r.index(static_cast<uint32_t>(i % W), static_cast<uint32_t>(i / W))] - TU) < 1;
    }
    assert_true(good > 0.9 * n);

    // Only the planes asked for.
    const lf::Result only_d0 = e.result(lf::Estimator::plane_d0);
    assert_true(same_bits(only_d0.d0, r.d0));
    assert_true(only_d0.u.empty() && only_d0.v.empty() && only_d0.d1.empty() && only_d0.confidence.empty() &&
                only_d0.valid.empty());

    // Borrowed views: the same values, in place.
    const lf::ResultViews v = e.views();
    assert_int_equal(v.width, W);
    assert_int_equal(v.height, H);
    for (uint32_t y = 0; y < H; y += 7)
        for (uint32_t x = 0; x < W; x += 5) {
            assert_true(lf::ResultViews::at(v.u, x, y) == r.u[r.index(x, y)]);
            assert_true(lf::ResultViews::at(v.d1, x, y) == r.d1[r.index(x, y)]);
            assert_int_equal(lf::ResultViews::at_u8(v.valid, x, y), 1);
        }

    // 3-D: Z = fx * baseline / d0 on valid pixels.
    const lf::Points3d p = e.points3d();
    assert_int_equal(p.points.size(), 3 * n);
    assert_int_equal(p.motion.size(), 3 * n);
    std::size_t valid3d = 0;
    for (std::size_t i = 0; i < n; ++i) {
        if (p.valid[i] == 0) continue;
        ++valid3d;
        assert_true(std::fabs(p.points[3 * i + 2] - 50.0f / r.d0[i]) < 1e-3f * p.points[3 * i + 2]);
        assert_true(std::isfinite(p.motion[3 * i]));
    }
    assert_true(valid3d > 0.9 * n);

    // Ego-motion: one rigid plane moving, so the object motion is X1 - T X0 and about 0.
    const lf::EgoMotion ego = e.ego_motion();
    assert_true(ego.inliers > 0 && ego.inliers <= ego.candidates);
    assert_true(ego.transform[15] == 1.0 && ego.transform[12] == 0.0);
    const lf::ObjectMotion om = e.object_motion();
    assert_int_equal(om.motion.size(), 3 * n);
    std::size_t still = 0;
    for (std::size_t i = 0; i < n; ++i) {
        assert_int_equal(om.valid[i], p.valid[i]);
        if (om.valid[i] == 0) {
            assert_true(std::isnan(om.motion[3 * i]));
            continue;
        }
        double sq = 0;
        for (int k = 0; k < 3; ++k) {
            const double *T = &ego.transform[4 * k];
            const double want = p.points[3 * i + k] + p.motion[3 * i + k] -
                                (T[0] * p.points[3 * i] + T[1] * p.points[3 * i + 1] + T[2] * p.points[3 * i + 2] + T[3]);
            assert_true(std::fabs(om.motion[3 * i + k] - want) < 1e-4 * (1 + std::fabs(want)));
            sq += want * want;
        }
        still += sq < 0.02 * 0.02;
    }
    assert_true(still > 0.9 * n);

#if LIDARFLOW_USE_OPENCV
    const cv::Mat omm = e.object_motion_mat();
    assert_int_equal(omm.type(), CV_32FC3);
    assert_memory_equal(omm.ptr<float>(0), om.motion.data(), 3 * W * sizeof(float));
    const cv::Matx44d Tm = ego.matx();
    assert_true(Tm(3, 3) == 1.0 && Tm(0, 3) == ego.transform[3]);
    const cv::Mat flow = e.flow(), d0 = e.disparity0(), d1 = e.disparity1(), conf = e.confidence(),
                  mask = e.valid_mask(), pts = e.points(), mot = e.motion();
    assert_int_equal(flow.type(), CV_32FC2);
    assert_int_equal(d0.type(), CV_32FC1);
    assert_int_equal(d1.type(), CV_32FC1);
    assert_int_equal(conf.type(), CV_32FC1);
    assert_int_equal(mask.type(), CV_8UC1);
    assert_int_equal(pts.type(), CV_32FC3);
    assert_int_equal(mot.type(), CV_32FC3);
    assert_true(flow.rows == H && flow.cols == W && pts.rows == H && pts.cols == W);
    assert_int_equal(cv::countNonZero(mask == 255), W * H);
    for (uint32_t y = 0; y < H; ++y)
        for (uint32_t x = 0; x < W; ++x) {
            const std::size_t i = r.index(x, y);
            const cv::Vec2f f = flow.at<cv::Vec2f>(static_cast<int>(y), static_cast<int>(x));
            assert_true(f[0] == r.u[i] && f[1] == r.v[i]);
            assert_true(d0.at<float>(static_cast<int>(y), static_cast<int>(x)) == r.d0[i]);
            assert_true(d1.at<float>(static_cast<int>(y), static_cast<int>(x)) == r.d1[i]);
            assert_true(conf.at<float>(static_cast<int>(y), static_cast<int>(x)) == r.confidence[i]);
            const cv::Vec3f q = pts.at<cv::Vec3f>(static_cast<int>(y), static_cast<int>(x));
            assert_memory_equal(&q[0], &p.points[3 * i], 3 * sizeof(float));
        }
    // Copies: they outlive the estimator's next result.
    e.reset();
    assert_true(flow.at<cv::Vec2f>(0, 0)[0] == r.u[0]);
#endif
}

// Estimator::quality: ok on the scene; its left and right swapped, flagged and named.
void test_quality(void **) {
    Scene sc;
    lf::Estimator e(sc.calibration(), scene_options("matching"));
    expect_error([&] { e.quality(); }, LF_ERR_NOT_READY, "", "quality before a push");
    push_pair(e, sc);
    const lf::Quality ok = e.quality();
    if (!ok.ok()) fail_msg("%s", ok.reason.c_str());
    assert_true(ok.names().empty() && ok.reason.empty());

    lf::Estimator swapped(sc.calibration(), scene_options("matching"));
    swapped.push(0, sc.image(sc.s.right0), sc.image(sc.s.left0));
    swapped.push(1, sc.image(sc.s.right1), sc.image(sc.s.left1));
    const lf::Quality q = swapped.quality();
    assert_true(q.has(LF_QUALITY_LEFT_RIGHT_SWAPPED) && !q.has(LF_QUALITY_BLANK_FRAME));
    assert_int_equal(q.names().size(), 1);
    assert_string_equal(q.names()[0].c_str(), "left_right_swapped");
    assert_true(q.reason.find("negative disparity") != std::string::npos);
}

void test_nan_holes(void **) {
    Scene sc;
    lf::Estimator e(sc.calibration(), scene_options("sparse"));
    push_pair(e, sc);
    const lf::Result r = e.result();
    assert_true(r.info.last_stage == lf::Stage::sparse);
    const lf::ResultViews raw = e.views();
    const lf::Points3d p = e.points3d();
    std::size_t holes = 0, valid = 0;
    for (uint32_t y = 0; y < H; ++y)
        for (uint32_t x = 0; x < W; ++x) {
            const std::size_t i = r.index(x, y);
            if (r.valid[i] != 0) {
                ++valid;
                assert_true(std::isfinite(r.u[i]) && std::isfinite(r.v[i]) && std::isfinite(r.d0[i]) &&
                            std::isfinite(r.d1[i]));
                continue;
            }
            ++holes;
            assert_true(std::isnan(r.u[i]) && std::isnan(r.v[i]) && std::isnan(r.d0[i]) && std::isnan(r.d1[i]));
            assert_true(r.confidence[i] == 0.0f);
            // The C ABI's own values there are NaN too; the views show them as they are.
            assert_true(std::isnan(lf::ResultViews::at(raw.u, x, y)) && std::isnan(lf::ResultViews::at(raw.d0, x, y)));
            assert_int_equal(p.valid[i], 0);
            assert_true(std::isnan(p.points[3 * i]) && std::isnan(p.motion[3 * i + 2]));
        }
    assert_true(holes > 0);
    assert_true(valid > 0);
    // No stage 4, no ego-motion: the reason comes with the error.
    expect_error([&] { e.ego_motion(); }, LF_ERR_BAD_STATE, "before interpolation", "ego_motion of a sparse result");
    expect_error([&] { e.object_motion(); }, LF_ERR_BAD_STATE, "before interpolation",
                 "object_motion of a sparse result");

#if LIDARFLOW_USE_OPENCV
    const cv::Mat flow = e.flow(), d0 = e.disparity0(), d1 = e.disparity1(), mask = e.valid_mask(), pts = e.points();
    cv::Mat nan_u(H, W, CV_8UC1), nan_d0(H, W, CV_8UC1), nan_d1(H, W, CV_8UC1), nan_pts(H, W, CV_8UC1);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const cv::Vec2f f = flow.at<cv::Vec2f>(y, x);
            assert_true(std::isnan(f[0]) == std::isnan(f[1]));
            nan_u.at<uint8_t>(y, x) = std::isnan(f[0]) ? 0 : 255;
            nan_d0.at<uint8_t>(y, x) = std::isnan(d0.at<float>(y, x)) ? 0 : 255;
            nan_d1.at<uint8_t>(y, x) = std::isnan(d1.at<float>(y, x)) ? 0 : 255;
            nan_pts.at<uint8_t>(y, x) = std::isnan(pts.at<cv::Vec3f>(y, x)[0]) ? 0 : 255;
        }
    assert_int_equal(cv::countNonZero(nan_u != mask), 0);
    assert_int_equal(cv::countNonZero(nan_d0 != mask), 0);
    assert_int_equal(cv::countNonZero(nan_d1 != mask), 0);
    assert_int_equal(cv::countNonZero(mask), static_cast<int>(valid));
    assert_int_equal(cv::countNonZero(nan_pts & ~mask), 0);  // no point where the result is a hole
#endif
}

// Equivalent inputs give bit-identical results: strided raw buffers, LiDAR from a Mat, cv::Mat
// ROIs and continuous Mats, BGR Mats and BGR raw buffers.
void test_inputs(void **) {
    Scene sc;
    auto run = [&](auto &&push) {
        lf::Estimator e(sc.calibration(), scene_options("matching"));
        push(e);
        return e.result();
    };
    const lf::Result ref = run([&](lf::Estimator &e) { push_pair(e, sc); });

    // Raw gray buffers with a stride of W + 13 bytes.
    const int stride = W + 13;
    std::vector<uint8_t> l0(stride * H), r0(stride * H), l1(stride * H), r1(stride * H);
    for (int y = 0; y < H; ++y) {
        std::memcpy(&l0[y * stride], sc.s.left0 + y * W, W);
        std::memcpy(&r0[y * stride], sc.s.right0 + y * W, W);
        std::memcpy(&l1[y * stride], sc.s.left1 + y * W, W);
        std::memcpy(&r1[y * stride], sc.s.right1 + y * W, W);
    }
    const lf::LidarView lidar = lf::LidarView::disparities(sc.lidar.data(), sc.lidar.size() / 3);
    const lf::Result strided = run([&](lf::Estimator &e) {
        e.push(0, lf::ImageView::gray8(l0.data(), W, H, stride), lf::ImageView::gray8(r0.data(), W, H, stride), lidar);
        e.push(100000, lf::ImageView::gray8(l1.data(), W, H, stride), lf::ImageView::gray8(r1.data(), W, H, stride),
               lidar);
    });
    assert_true(same_bits(strided.u, ref.u) && same_bits(strided.d1, ref.d1) && strided.valid == ref.valid);

#if LIDARFLOW_USE_OPENCV
    // ROIs of larger Mats (not continuous), LiDAR as an N x 4 Mat (KITTI-like records).
    auto mat = [&](const uint8_t *p) { return cv::Mat(H, W, CV_8UC1, const_cast<uint8_t *>(p)); };
    auto roi = [&](const uint8_t *p) {
        cv::Mat big(H + 9, W + 21, CV_8UC1, cv::Scalar(77));
        mat(p).copyTo(big(cv::Rect(11, 5, W, H)));
        return cv::Mat(big(cv::Rect(11, 5, W, H)));
    };
    cv::Mat records(static_cast<int>(sc.lidar.size() / 3), 4, CV_32FC1, cv::Scalar(0.25f));
    for (int i = 0; i < records.rows; ++i)
        for (int k = 0; k < 3; ++k) records.at<float>(i, k) = sc.lidar[3 * static_cast<std::size_t>(i) + k];
    const cv::Mat L0 = roi(sc.s.left0), R0 = roi(sc.s.right0), L1 = roi(sc.s.left1), R1 = roi(sc.s.right1);
    assert_false(L0.isContinuous());
    const lf::LidarView mat_lidar = lf::LidarView::from_mat(lf::LidarKind::disparity, records);
    assert_int_equal(mat_lidar.stride_bytes, 16);
    const lf::Result from_roi = run([&](lf::Estimator &e) {
        e.push(0, L0, R0, mat_lidar);
        e.push(100000, L1, R1, mat_lidar);
    });
    assert_true(same_bits(from_roi.u, ref.u) && same_bits(from_roi.v, ref.v) && same_bits(from_roi.d0, ref.d0) &&
                from_roi.valid == ref.valid);

    // BGR: an ROI of a BGR Mat and the same pixels as a packed raw BGR buffer.
    auto bgr_roi = [&](const uint8_t *p) {
        cv::Mat g = mat(p), planes[3] = {g, (g + 40) / 2, 255 - g}, bgr, big(H + 4, W + 6, CV_8UC3, cv::Scalar::all(0));
        cv::merge(planes, 3, bgr);
        bgr.copyTo(big(cv::Rect(3, 2, W, H)));
        return cv::Mat(big(cv::Rect(3, 2, W, H)));
    };
    const cv::Mat B0 = bgr_roi(sc.s.left0), C0 = bgr_roi(sc.s.right0), B1 = bgr_roi(sc.s.left1),
                  C1 = bgr_roi(sc.s.right1);
    const lf::Result bgr = run([&](lf::Estimator &e) {
        e.push(0, B0, C0, lidar);
        e.push(100000, B1, C1, lidar);
    });
    assert_int_equal(bgr.info.width, W);
    const cv::Mat P0 = B0.clone(), Q0 = C0.clone(), P1 = B1.clone(), Q1 = C1.clone();
    const lf::Result bgr_raw = run([&](lf::Estimator &e) {
        e.push(0, lf::ImageView::bgr8(P0.data, W, H), lf::ImageView::bgr8(Q0.data, W, H), lidar);
        e.push(100000, lf::ImageView::bgr8(P1.data, W, H), lf::ImageView::bgr8(Q1.data, W, H), lidar);
    });
    assert_true(same_bits(bgr.u, bgr_raw.u) && same_bits(bgr.d0, bgr_raw.d0) && bgr.valid == bgr_raw.valid);
#endif
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version), cmocka_unit_test(test_options),  cmocka_unit_test(test_errors),
        cmocka_unit_test(test_dense_run), cmocka_unit_test(test_quality), cmocka_unit_test(test_nan_holes), cmocka_unit_test(test_inputs),
        cmocka_unit_test(test_log_handler_not_from_a_handler), cmocka_unit_test(test_cpp_checks),
        cmocka_unit_test(test_frames_in_flight),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
