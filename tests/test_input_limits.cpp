// SPDX-License-Identifier: MIT
// The accepted input ranges of core/limits.hpp, enforced by the core whatever the entry point:
// image sides (SGM's speckle filter corrupted its heap on 65535x2 frames), LiDAR disparities
// (3e38 overflowed the matcher's float -> int conversions), cameras (finite values whose
// products overflow), and the readers' checks: PNG signature and size before decoding, frame
// ids that reach file paths, output folders proven writable before the work.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "consistency/sgm_check.hpp"
#include "core/limits.hpp"
#include "io/calib.hpp"
#include "io/image_file.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/output_folder.hpp"
#include "lidar/projection.hpp"
#include "pipeline/estimator.hpp"
#include "test_support.hpp"

using namespace lidarflow;
using lidarflow::test::expect_error;
namespace fs = std::filesystem;

namespace {

// The message of the lidarflow::Error that f throws with `code` ("" when it does not throw).
template <class F>
std::string message_of(F &&f, ErrorCode code) {
    try {
        f();
    } catch (const Error &e) {
        assert_int_equal(static_cast<int>(e.code()), static_cast<int>(code));
        return e.what();
    }
    fail_msg("expected a lidarflow::Error");
    return "";
}

void expect_in(const std::string &message, const char *needle) {
    if (message.find(needle) == std::string::npos) fail_msg("'%s' lacks '%s'", message.c_str(), needle);
}

cv::Mat noise(int w, int h, int seed) {
    cv::Mat m(h, w, CV_8UC1);
    cv::RNG rng(static_cast<uint64>(seed));
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
}

pipeline::FrameInput frame_of(int w, int h) {
    pipeline::FrameInput in;
    in.left0 = noise(w, h, 1);
    in.right0 = noise(w, h, 2);
    in.left1 = noise(w, h, 3);
    in.right1 = noise(w, h, 4);
    in.lidar0 = {w, h, {}};
    in.lidar1 = {w, h, {}};
    return in;
}

pipeline::EstimatorOptions cheap_options() {
    pipeline::EstimatorOptions o;
    o.last_stage = pipeline::Stage::Matching;
    return o;
}

StereoCamera camera(double fx, double baseline) { return {fx, fx, 10, 10, baseline}; }

// --- image sides -----------------------------------------------------------------

void sgm_refuses_sizes_its_speckle_filter_cannot_index(void **) {
    // Without the check, OpenCV's speckle filter wrote through 16-bit pixel coordinates.
    const cv::Mat wide = noise(32768, 2, 5);
    expect_in(message_of([&] { consistency::compute_sgm_disparity(wide, wide); }, ErrorCode::InvalidArgument),
              "exceed the 32767 px");
    // The padding counts: 32767 - 128 + 1 columns plus 128 px of padding are too many.
    const cv::Mat padded = noise(32767 - 127, 2, 6);
    expect_error([&] { consistency::compute_sgm_disparity(padded, padded); }, ErrorCode::InvalidArgument);
    // The widest image the estimator accepts runs.
    const cv::Mat widest = noise(kMaxImageSide, 2, 7);
    const DisparityMap d = consistency::compute_sgm_disparity(widest, widest);
    assert_int_equal(d.cols, kMaxImageSide);
}

void estimator_refuses_images_above_the_side_bound(void **) {
    const pipeline::Estimator est(cheap_options());
    const pipeline::FrameInput in = frame_of(kMaxImageSide + 1, 2);
    expect_in(message_of([&] { est.run(in); }, ErrorCode::InvalidArgument), "larger than 16384 px per side");
    pipeline::FrameInput tall = frame_of(2, kMaxImageSide + 1);
    expect_error([&] { est.run(tall); }, ErrorCode::InvalidArgument);
}

// --- LiDAR disparities -----------------------------------------------------------

void lidar_disparities_outside_the_range_are_refused(void **) {
    for (float bad : {3e38f, kMaxLidarDisparity * 1.0001f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                      std::numeric_limits<float>::infinity()}) {
        const SparseLidar l{8, 8, {{1, 1, bad}}};
        expect_in(message_of([&] { l.validate(8, 8, "lidar"); }, ErrorCode::InvalidArgument), "outside [0, 16384]");
    }
    for (float good : {0.0f, 1e-40f, kMaxLidarDisparity}) {
        const SparseLidar l{8, 8, {{1, 1, good}}};
        l.validate(8, 8, "lidar");
    }
    // The estimator itself refuses them, at full and reduced processing scale.
    pipeline::FrameInput in = frame_of(64, 48);
    in.lidar0.points.push_back({10, 10, 3e38f});
    for (double scale : {1.0, 0.5}) {
        pipeline::EstimatorOptions o = cheap_options();
        o.processing_scale = scale;
        expect_in(message_of([&] { pipeline::Estimator(o).run(in); }, ErrorCode::InvalidArgument),
                  "FrameInput: lidar0 has a disparity");
    }
}

void projection_drops_points_with_disparities_out_of_range(void **) {
    // fx * baseline = 1e10 px m: a point 1 m away has a disparity of 1e10 px.
    const io::CamToCamCalib calib = io::calib_from_camera({1e6, 1e6, 4, 4, 1e4});
    const SparseLidar near = lidar::project_to_left(std::vector<cv::Point3d>{{0, 0, 1.0}}, calib, {8, 8});
    assert_int_equal(near.points.size(), 0);
    const SparseLidar far = lidar::project_to_left(std::vector<cv::Point3d>{{0, 0, 1e7}}, calib, {8, 8});
    assert_int_equal(far.points.size(), 1);
    assert_true(far.points[0].disparity == 1000.0f);
}

// --- cameras ---------------------------------------------------------------------

void cameras_outside_the_ranges_are_refused(void **) {
    assert_string_equal(camera_range_error(camera(721.5, 0.54)).c_str(), "");
    assert_string_equal(camera_range_error(camera(kMinFocal, kMaxBaseline)).c_str(), "");
    assert_string_equal(camera_range_error(camera(kMaxFocal, kMinBaseline)).c_str(), "");
    expect_in(camera_range_error(camera(1e-300, 0.5)), "fx = 1e-300 px is outside [1, 1e+06]");
    expect_in(camera_range_error(camera(1e200, 1e200)), "fx = 1e+200 px is outside");
    expect_in(camera_range_error(camera(700, 1e200)), "baseline = 1e+200 m is outside [0.0001, 10000]");
    expect_in(camera_range_error(camera(700, INFINITY)), "baseline = inf m");
    expect_in(camera_range_error({700, 700, NAN, 0, 0.5}), "cx = nan px");
    expect_in(camera_range_error({700, 700, 0, -1e7, 0.5}), "cy = -1e+07 px");
    assert_true(camera_unknown(StereoCamera{}));
    assert_false(camera_unknown(camera(700, 0.5)));

    // The core refuses a known camera out of range; the all-zero unknown rig stays accepted.
    const pipeline::Estimator est(cheap_options());
    pipeline::FrameInput in = frame_of(64, 48);
    in.camera = camera(1e200, 1e200);
    expect_in(message_of([&] { est.run(in); }, ErrorCode::InvalidArgument), "FrameInput: camera: fx = 1e+200");
    in.camera = {0, 0, 0, 0, -1};  // not all zero: a broken rig, not an unknown one
    expect_error([&] { est.run(in); }, ErrorCode::InvalidArgument);
    expect_error([&] { io::calib_from_camera(camera(1e200, 1e200)); }, ErrorCode::InvalidArgument);
}

std::string cam_to_cam(const std::string &p2_tx, const std::string &p3_tx, const std::string &fx = "700") {
    return "R_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: " + fx + " 0 600 " + p2_tx + " 0 " + fx +
           " 170 0 0 0 1 0\nP_rect_03: " + fx + " 0 600 " + p3_tx + " 0 " + fx + " 170 0 0 0 1 0\n";
}

void calibration_files_with_overflowing_cameras_are_refused(void **) {
    assert_true(io::parse_calib_cam_to_cam(cam_to_cam("0", "-378"), "ok").camera.baseline == 0.54);
    // Finite entries, infinite baseline: (1e308 - -1e308) / 700.
    expect_in(message_of([] { io::parse_calib_cam_to_cam(cam_to_cam("1e308", "-1e308"), "inf"); }, ErrorCode::Format),
              "baseline = inf m is outside");
    expect_in(message_of([] { io::parse_calib_cam_to_cam(cam_to_cam("0", "-1", "1e-300"), "tiny"); }, ErrorCode::Format),
              "fx = 1e-300 px is outside");
    expect_error([] { io::parse_calib_cam_to_cam(cam_to_cam("0", "-1e200", "1e200"), "huge"); }, ErrorCode::Format);
}

// --- PNG signature and size before decoding --------------------------------------

void writes(const fs::path &p, const std::string &bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
}

void non_png_files_are_refused_before_decoding(void **) {
    const fs::path dir = test::scratch_dir("input_limits_png");
    const cv::Mat img = noise(16, 8, 9);
    // Formats OpenCV decodes but the KITTI readers must not: saved under a .png name.
    for (const char *ext : {".bmp", ".tiff", ".pgm"}) {
        const fs::path real = dir / (std::string("image") + ext), fake = dir / (std::string("fake_") + (ext + 1) + ".png");
        if (!cv::imwrite(real.string(), img)) continue;  // an OpenCV built without this codec
        fs::rename(real, fake);
        assert_true(!cv::imread(fake.string(), cv::IMREAD_UNCHANGED).empty());  // OpenCV would decode it
        expect_in(message_of([&] { io::read_image(fake.string()); }, ErrorCode::Format), "not a PNG file");
        expect_in(message_of([&] { io::read_disparity_png(fake.string()); }, ErrorCode::Format), "not a PNG file");
        expect_error([&] { io::read_flow_png(fake.string()); }, ErrorCode::Format);
    }
    writes(dir / "short.png", "\x89PNG");
    expect_in(message_of([&] { io::read_image((dir / "short.png").string()); }, ErrorCode::Format), "not a PNG file");
    writes(dir / "no_ihdr.png", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(16, 'x'));
    expect_in(message_of([&] { io::read_image((dir / "no_ihdr.png").string()); }, ErrorCode::Format), "no IHDR");
    expect_error([&] { io::read_image((dir / "missing.png").string()); }, ErrorCode::Io);

    // A real PNG still reads.
    assert_true(cv::imwrite((dir / "good.png").string(), img));
    assert_int_equal(cv::norm(io::read_image((dir / "good.png").string()), img, cv::NORM_INF), 0);
}

void oversized_pngs_are_refused_from_their_header(void **) {
    const fs::path dir = test::scratch_dir("input_limits_size");
    const fs::path wide = dir / "wide.png";
    assert_true(cv::imwrite(wide.string(), cv::Mat(2, 65535, CV_8UC1, cv::Scalar(7))));
    expect_in(message_of([&] { io::read_image(wide.string()); }, ErrorCode::InvalidArgument),
              "is 65535x2, larger than 16384 px per side");
    // A header claiming 100000 x 100000 px is refused without decoding (the data would not
    // even be there): patch the IHDR of a small PNG.
    const fs::path small = dir / "small.png";
    assert_true(cv::imwrite(small.string(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(256))));
    std::string bytes;
    {
        std::ifstream in(small, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    const unsigned char huge[4] = {0x00, 0x01, 0x86, 0xa0};  // 100000, big-endian
    std::memcpy(&bytes[16], huge, 4);
    std::memcpy(&bytes[20], huge, 4);
    writes(dir / "huge.png", bytes);
    expect_in(message_of([&] { io::read_disparity_png((dir / "huge.png").string()); }, ErrorCode::InvalidArgument),
              "100000x100000");
    assert_int_equal(io::read_disparity_png(small.string()).cols, 4);
}

// read_any_image (lidarflow run, viz --image): PNG, JPEG, BMP and PGM/PPM told by signature,
// their size read from the header before decoding, the same limits as PNG.
void camera_images_in_other_formats_are_read_with_the_same_checks(void **) {
    const fs::path dir = test::scratch_dir("input_limits_any_image");
    const cv::Mat img = noise(16, 8, 9);
    cv::Mat bgr;
    cv::merge(std::vector<cv::Mat>{img, 255 - img, img / 2}, bgr);
    for (const cv::Mat &m : {img, bgr})
        for (const char *ext : {".png", ".bmp", ".pgm", ".ppm", ".jpg"}) {
            if (m.channels() == 3 && std::string(ext) == ".pgm") continue;
            if (m.channels() == 1 && std::string(ext) == ".ppm") continue;
            // Saved under a misleading name: the signature decides.
            const fs::path real = dir / (std::string("image") + ext), named = dir / (std::string(ext + 1) + "_as.dat");
            if (!cv::imwrite(real.string(), m)) continue;  // an OpenCV built without this codec
            fs::rename(real, named);
            const cv::Mat back = io::read_any_image(named.string());
            assert_true(back.size() == m.size() && back.channels() == m.channels() && back.depth() == CV_8U);
            if (std::string(ext) == ".jpg")  // lossy, and the image is noise: on average close
                assert_true(cv::norm(back, m, cv::NORM_L1) / static_cast<double>(m.total() * m.channels()) < 48);
            else
                assert_true(cv::norm(back, m, cv::NORM_INF) == 0);
        }
    // Sizes from the header: a JPEG whose frame header claims 60000 x 60000, a BMP claiming a
    // negative width and a PGM claiming 100000 px are refused before any decoding.
    assert_true(cv::imwrite((dir / "small.jpg").string(), bgr));
    std::string jpg;
    {
        std::ifstream in(dir / "small.jpg", std::ios::binary);
        jpg.assign(std::istreambuf_iterator<char>(in), {});
    }
    const size_t sof = jpg.find("\xFF\xC0");
    assert_true(sof != std::string::npos);
    jpg[sof + 5] = jpg[sof + 7] = static_cast<char>(0xEA);  // height, width = 0xEA60 = 60000
    jpg[sof + 6] = jpg[sof + 8] = static_cast<char>(0x60);
    writes(dir / "huge.jpg", jpg);
    expect_in(message_of([&] { io::read_any_image((dir / "huge.jpg").string()); }, ErrorCode::InvalidArgument),
              "is 60000x60000, larger than 16384 px per side");
    assert_true(cv::imwrite((dir / "small.bmp").string(), img));
    std::string bmp;
    {
        std::ifstream in(dir / "small.bmp", std::ios::binary);
        bmp.assign(std::istreambuf_iterator<char>(in), {});
    }
    std::memset(&bmp[18], 0xff, 4);  // width -1
    writes(dir / "negative.bmp", bmp);
    expect_in(message_of([&] { io::read_any_image((dir / "negative.bmp").string()); }, ErrorCode::Format),
              "corrupt BMP");
    writes(dir / "huge.pgm", "P5\n# a comment\n100000 2\n255\n" + std::string(20, 'x'));
    expect_in(message_of([&] { io::read_any_image((dir / "huge.pgm").string()); }, ErrorCode::InvalidArgument),
              "is 100000x2");
    writes(dir / "truncated.jpg", jpg.substr(0, 4));
    expect_error([&] { io::read_any_image((dir / "truncated.jpg").string()); }, ErrorCode::Format);
    writes(dir / "text.png", "hello, not an image");
    expect_in(message_of([&] { io::read_any_image((dir / "text.png").string()); }, ErrorCode::Format),
              "not an image file this reads");
    expect_error([&] { io::read_any_image((dir / "missing.jpg").string()); }, ErrorCode::Io);
    // 16-bit and 4-channel images are not camera images here.
    assert_true(cv::imwrite((dir / "deep.png").string(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(300))));
    expect_in(message_of([&] { io::read_any_image((dir / "deep.png").string()); }, ErrorCode::Format), "8-bit");
}

// --- frame ids and output folders ------------------------------------------------

void frame_ids_that_are_not_six_digits_never_reach_a_path(void **) {
    const io::KittiLayout k{"/data"};
    assert_string_equal(k.left("000002", 1).c_str(), "/data/image_2/000002_11.png");
    for (const char *bad : {"../../x", "", "00002", "0000020", "00000a", "/etc/p", "00 002"}) {
        expect_in(message_of([&] { k.left(bad, 0); }, ErrorCode::InvalidArgument), "is not a KITTI frame id");
        expect_error([&] { k.gt_flow(bad); }, ErrorCode::InvalidArgument);
        expect_error([&] { k.calib_cam_to_cam(bad); }, ErrorCode::InvalidArgument);
        expect_error([&] { k.calib_velo_to_cam(bad); }, ErrorCode::InvalidArgument);
        expect_error([&] { k.velodyne(bad); }, ErrorCode::InvalidArgument);
        expect_error([&] { k.est_disp0(bad); }, ErrorCode::InvalidArgument);
        expect_error([&] { io::KittiLayout::check_id(bad); }, ErrorCode::InvalidArgument);
    }
    // Listing a folder yields only well-formed ids.
    const fs::path root = test::scratch_dir("input_limits_ids");
    fs::create_directories(root / "image_2");
    for (const char *name : {"000001_10.png", "abcdef_10.png", "000002_11.png", "000003_10.png"})
        writes(root / "image_2" / name, "");
    const std::vector<std::string> ids = io::KittiLayout{root.string()}.frame_ids();
    assert_int_equal(ids.size(), 2);
    assert_string_equal(ids[0].c_str(), "000001");
    assert_string_equal(ids[1].c_str(), "000003");
}

void output_folders_are_proven_writable(void **) {
    const fs::path dir = test::scratch_dir("input_limits_out");
    const fs::path nested = dir / "a" / "b";
    io::prepare_output_folder(nested.string());
    assert_true(fs::is_directory(nested));
    assert_true(fs::is_empty(nested));  // the probe file is gone
    writes(dir / "file", "x");
    expect_in(message_of([&] { io::prepare_output_folder((dir / "file" / "sub").string()); }, ErrorCode::Io),
              "cannot create output folder");
    expect_in(message_of([&] { io::prepare_output_folder((dir / "file").string()); }, ErrorCode::Io),
              "cannot create output folder");
    expect_error([&] { io::prepare_output_folder(""); }, ErrorCode::InvalidArgument);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(sgm_refuses_sizes_its_speckle_filter_cannot_index),
        cmocka_unit_test(estimator_refuses_images_above_the_side_bound),
        cmocka_unit_test(lidar_disparities_outside_the_range_are_refused),
        cmocka_unit_test(projection_drops_points_with_disparities_out_of_range),
        cmocka_unit_test(cameras_outside_the_ranges_are_refused),
        cmocka_unit_test(calibration_files_with_overflowing_cameras_are_refused),
        cmocka_unit_test(non_png_files_are_refused_before_decoding),
        cmocka_unit_test(oversized_pngs_are_refused_from_their_header),
        cmocka_unit_test(camera_images_in_other_formats_are_read_with_the_same_checks),
        cmocka_unit_test(frame_ids_that_are_not_six_digits_never_reach_a_path),
        cmocka_unit_test(output_folders_are_proven_writable),
    };
    return cmocka_run_group_tests_name("input_limits", tests, nullptr, nullptr);
}
