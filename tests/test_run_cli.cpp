// SPDX-License-Identifier: MIT
// `lidarflow run` on a rendered frame: raw Velodyne scans at t0 and t1 (--velo0/--velo1 with
// --calib-velo) land in the images with the expected counts, `kitti --lidar velodyne` takes a
// t1 scan when the layout has one; every --format reads back as the same result; the --points
// PLY holds one finite point per valid pixel; progress lines appear when the output is piped;
// bad arguments exit 2 and bad files 1. Runs the built binary ($LIDARFLOW_CLI, set by CTest).
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/point_cloud.hpp"
#include "io/result_formats.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
// cmocka 1.1.5's header lacks extern "C" and its fail() macro breaks <ios>: include it last.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;
namespace fs = std::filesystem;

namespace {

using Result = test::CliRun;

// The scratch dir names where a test's files go; the output comes back through a pipe.
Result run(const std::string &args, const fs::path &) { return test::run_cli(args); }

std::string q(const fs::path &p) { return test::quoted(p); }

void expect_contains(const Result &r, const std::string &what) {
    if (r.output.find(what) != std::string::npos) return;
    std::printf("%s", r.output.c_str());
    fail_msg("expected \"%s\" in the output above", what.c_str());
}

// Velodyne axes (x forward, y left, z up) -> camera 0 (x right, y down, z forward), no offset.
void write_velo_calib(const fs::path &path) {
    fs::create_directories(path.parent_path());
    std::ofstream(path) << "calib_time: test\nR: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 0\n";
}

// A scan whose points project to the given pixels at depth z, plus `outside` points that must
// not land in the image (behind the camera, or beyond its right edge).
void write_scan(const fs::path &path, const StereoCamera &cam, const std::vector<cv::Point> &pixels, double z,
                int outside) {
    fs::create_directories(path.parent_path());
    std::ofstream f(path, std::ios::binary);
    auto put = [&](double xc, double yc, double zc) {
        const float rec[4] = {static_cast<float>(zc), static_cast<float>(-xc), static_cast<float>(-yc), 0.5f};
        f.write(reinterpret_cast<const char *>(rec), sizeof rec);
    };
    for (const cv::Point &p : pixels) put((p.x - cam.cx) * z / cam.fx, (p.y - cam.cy) * z / cam.fy, z);
    for (int k = 0; k < outside; ++k) {
        if (k % 2)
            put(0.0, 0.0, -5.0);  // behind
        else
            put(10.0 * z, 0.0, z);  // far to the right
    }
}

std::vector<cv::Point> grid_pixels(int n, int x0, int y0) {
    std::vector<cv::Point> out;
    for (int i = 0; i < n; ++i) out.emplace_back(x0 + 23 * (i % 10), y0 + 17 * (i / 10));
    return out;
}

struct Scene {
    fs::path dir, root;
    io::KittiLayout k;
    StereoCamera cam;
    std::string images;  // the four --left0 .. --right1 options
};

Scene make_scene(const std::string &name) {
    Scene s;
    s.dir = test::scratch_dir(name);
    s.root = s.dir / "kitti";
    const Result r = run("synth --out " + q(s.root) + " --width 320 --height 96", s.dir);
    if (r.code != 0) fail_msg("synth failed: %s", r.output.c_str());
    s.k = io::KittiLayout{s.root.string()};
    s.cam = io::read_calib_cam_to_cam(s.k.calib_cam_to_cam("000000")).camera;
    s.images = " --left0 " + q(s.k.left("000000", 0)) + " --right0 " + q(s.k.right("000000", 0)) + " --left1 " +
               q(s.k.left("000000", 1)) + " --right1 " + q(s.k.right("000000", 1));
    write_velo_calib(s.k.calib_velo_to_cam("000000"));
    write_scan(s.k.velodyne("000000"), s.cam, grid_pixels(12, 10, 10), 12.0, 4);
    return s;
}

void test_velodyne_inputs(void **) {
    const Scene s = make_scene("cli_run_velodyne");
    const fs::path t1 = s.dir / "t1.bin";
    write_scan(t1, s.cam, grid_pixels(7, 30, 40), 9.0, 3);
    const std::string calib =
        " --calib " + q(s.k.calib_cam_to_cam("000000")) + " --calib-velo " + q(s.k.calib_velo_to_cam("000000"));
    Result r = run("run" + s.images + calib + " --velo0 " + q(s.k.velodyne("000000")) + " --velo1 " + q(t1) +
                       " --stage matching --out " + q(s.dir / "o"),
                   s.dir);
    if (r.code != 0) fail_msg("run --velo0 --velo1 failed: %s", r.output.c_str());
    expect_contains(r, "LiDAR 12 points at t0, 7 at t1");
    expect_contains(r, "16 points, 12 in the image");
    expect_contains(r, "run: estimating");  // progress, though nothing here is a terminal

    // kitti --lidar velodyne: without velodyne/ID_11.bin D1 is empty and the output says so; with
    // it, the t1 scan is used.
    const std::string kitti = "kitti --root " + q(s.root) + " --lidar velodyne --stage matching --no-viz";
    r = run(kitti, s.dir);
    if (r.code != 0) fail_msg("kitti --lidar velodyne failed: %s", r.output.c_str());
    expect_contains(r, "LiDAR 12 + 0 points");
    expect_contains(r, "no scan at t1 (velodyne/ID_11.bin) for 000000");
    expect_contains(r, "[1/1] 000000: loading  (elapsed ");  // piped progress lines
    expect_contains(r, ", ETA ");
    expect_contains(r, "kitti: done in ");
    assert_true(r.output.find('\r') == std::string::npos);  // plain lines when piped
    fs::copy_file(t1, s.k.velodyne_t1("000000"));
    r = run(kitti, s.dir);
    assert_int_equal(r.code, 0);
    expect_contains(r, "LiDAR 12 + 7 points");
    assert_true(r.output.find("no scan at t1") == std::string::npos);
}

void test_formats_and_points(void **) {
    const Scene s = make_scene("cli_run_formats");
    const fs::path out = s.dir / "o", ply = s.dir / "cloud.ply";
    // Stage sparse leaves holes, so the round trips cover invalid pixels too.
    const Result r = run("run" + s.images + " --lidar0 " + q(s.k.lidar("000000", 0)) + " --calib " +
                             q(s.k.calib_cam_to_cam("000000")) + " --stage sparse --format kitti,flo,pfm,npy --points " +
                             q(ply) + " --id 000005 --out " + q(out),
                         s.dir);
    if (r.code != 0) fail_msg("run --format failed: %s", r.output.c_str());
    const io::KittiLayout o{out.string()};
    const DisparityMap d0_png = io::read_disparity_png(o.est_disp0("000005"));
    const FlowField flow_png = io::read_flow_png(o.est_flow("000005"));
    const cv::Mat d0_pfm = io::read_pfm((out / "disp_0" / "000005_10.pfm").string());
    const cv::Mat d0_npy = io::read_npy((out / "disp_0" / "000005_10.npy").string());
    const cv::Mat d1_npy = io::read_npy((out / "disp_1" / "000005_10.npy").string());
    const cv::Mat fl_pfm = io::read_pfm((out / "flow" / "000005_10.pfm").string());
    const cv::Mat fl_npy = io::read_npy((out / "flow" / "000005_10.npy").string());
    const cv::Mat valid_npy = io::read_npy((out / "valid" / "000005_10.npy").string());
    const FlowField fl_flo = io::read_flo((out / "flow" / "000005_10.flo").string());
    assert_true(d0_npy.size() == cv::Size(320, 96) && fl_npy.type() == CV_32FC2 && valid_npy.type() == CV_8UC1);
    int valid = 0, holes = 0, with_point = 0;
    for (int y = 0; y < 96; ++y)
        for (int x = 0; x < 320; ++x) {
            const float d = d0_npy.at<float>(y, x), dp = d0_pfm.at<float>(y, x);
            const cv::Vec2f f = fl_npy.at<cv::Vec2f>(y, x);
            const cv::Vec3f fp = fl_pfm.at<cv::Vec3f>(y, x);
            const bool ok = valid_npy.at<uint8_t>(y, x) == 1;
            assert_int_equal(ok, fp[2] == 1.0f);
            assert_int_equal(ok, disparity_valid(d0_png(y, x)));
            assert_int_equal(ok, flow_png.valid(y, x));
            assert_int_equal(ok, fl_flo.valid(y, x));
            if (!ok) {
                ++holes;
                assert_true(std::isnan(d) && std::isnan(dp) && std::isnan(f[0]) && std::isnan(f[1]) && fp[2] == 0.0f);
                continue;
            }
            ++valid;
            with_point += d > 0 && d1_npy.at<float>(y, x) > 0;
            assert_true(d == dp && f[0] == fp[0] && f[1] == fp[1]);
            assert_true(f[0] == fl_flo.u(y, x) && f[1] == fl_flo.v(y, x));
            // The PNG is the same value quantised by the devkit (1/256 px, 1/64 px).
            assert_true(std::fabs(d - d0_png(y, x)) <= 1.0f / 256 + 1e-4f);
            assert_true(std::fabs(f[0] - flow_png.u(y, x)) <= 1.0f / 64 + 1e-4f);
        }
    assert_true(valid > 100 && holes > 100);

    const std::vector<io::CloudPoint> cloud = io::read_ply(ply.string());
    assert_int_equal(cloud.size(), with_point);
    for (const io::CloudPoint &p : cloud) {
        assert_true(cv::checkRange(p.position) && cv::checkRange(p.motion));
        assert_true(p.position[2] > 0);
    }
    expect_contains(r, "wrote     " + ply.string() + ": " + std::to_string(cloud.size()) + " points");
    // Stage sparse: no ego-motion, so no object motion either (and run says why).
    expect_contains(r, "ego       not fitted: the result comes from a stage before interpolation");
    for (const io::CloudPoint &p : cloud) assert_false(p.has_object_motion);

    // viz reads every format run wrote: the same picture from each, and error maps against the
    // KITTI PNGs of the same result.
    cv::Mat first;
    for (const char *ext : {"png", "flo", "pfm", "npy"}) {
        const fs::path pic = s.dir / (std::string("flow_") + ext + ".png");
        const Result v = run("viz --flow " + q(out / "flow" / (std::string("000005_10.") + ext)) + " --max 20 --out " +
                                 q(pic),
                             s.dir);
        if (v.code != 0) fail_msg("viz --flow .%s failed: %s", ext, v.output.c_str());
        const cv::Mat m = io::read_image(pic.string());
        if (first.empty()) first = m;
        assert_true(m.size() == first.size());
        // The PNG is quantised to 1/64 px: a colour step or two at most.
        assert_true(cv::norm(m, first, cv::NORM_INF) <= 8);
    }
    for (const char *ext : {"pfm", "npy"}) {
        const std::string d = q(out / "disp_0" / (std::string("000005_10.") + ext));
        Result v = run("viz --disp " + d + " --out " + q(s.dir / "d.png"), s.dir);
        if (v.code != 0) fail_msg("viz --disp .%s failed: %s", ext, v.output.c_str());
        v = run("viz --disp " + d + " --gt " + q(o.est_disp0("000005")) + " --out " + q(s.dir / "de.png"), s.dir);
        if (v.code != 0) fail_msg("viz --disp .%s --gt failed: %s", ext, v.output.c_str());
    }
    {
        // A corrupt float file is a clear error, not a crash.
        std::ofstream(s.dir / "bad.pfm", std::ios::binary) << "PF\n16000 16000\n-1.0\n0123";
        const Result v = run("viz --flow " + q(s.dir / "bad.pfm") + " --out " + q(s.dir / "bad.png"), s.dir);
        assert_int_equal(v.code, 1);
        expect_contains(v, "bytes of data, the header announces");
    }

    // The bird's-eye view of it.
    const Result v = run("viz --points " + q(ply) + " --out " + q(s.dir / "bev.png") + " --range 40", s.dir);
    if (v.code != 0) fail_msg("viz --points failed: %s", v.output.c_str());
    const cv::Mat bev = io::read_image((s.dir / "bev.png").string());
    assert_int_equal(bev.cols, 600);
    assert_true(bev.rows > 600);  // + the speed colour bar
}

// The whole pipeline with the rig: run reports the ego-motion, its PLY carries the object motion
// (omx omy omz), and viz --points colours by it, saying so in its output and its legend.
void test_points_object_motion(void **) {
    const Scene s = make_scene("cli_run_object_motion");
    const fs::path ply = s.dir / "cloud.ply";
    const Result r = run("run" + s.images + " --lidar0 " + q(s.k.lidar("000000", 0)) + " --calib " +
                             q(s.k.calib_cam_to_cam("000000")) + " --preset realtime --points " + q(ply) + " --out " +
                             q(s.dir / "o"),
                         s.dir);
    if (r.code != 0) fail_msg("run --points failed: %s", r.output.c_str());
    expect_contains(r, "ego       T t = (");
    expect_contains(r, "red green blue, omx omy omz [m])");
    const std::vector<io::CloudPoint> cloud = io::read_ply(ply.string());
    assert_true(cloud.size() > 1000);
    std::vector<double> moving, still;
    for (const io::CloudPoint &p : cloud) {
        assert_true(p.has_object_motion && cv::checkRange(p.object_motion));
        moving.push_back(cv::norm(p.motion));
        still.push_back(cv::norm(p.object_motion));
    }
    std::nth_element(moving.begin(), moving.begin() + moving.size() / 2, moving.end());
    std::nth_element(still.begin(), still.begin() + still.size() / 2, still.end());
    std::printf("median |motion| %.3f m, |object motion| %.3f m\n", moving[moving.size() / 2], still[still.size() / 2]);
    // The synthetic camera moves: most of the world moves with it and stays still once it is removed.
    assert_true(moving[moving.size() / 2] > 0.1);
    assert_true(still[still.size() / 2] < 0.25 * moving[moving.size() / 2]);
    const Result v = run("viz --points " + q(ply) + " --out " + q(s.dir / "bev.png"), s.dir);
    if (v.code != 0) fail_msg("viz --points failed: %s", v.output.c_str());
    expect_contains(v, "colour = |object motion|, ego-motion removed");
    const cv::Mat bev = io::read_image((s.dir / "bev.png").string());
    assert_true(bev.cols == 600 && bev.rows > 600);  // + the colour bar of the object motion
}

void expect_failure(const std::string &args, const fs::path &dir, int code, const std::string &message) {
    const Result r = run(args, dir);
    if (r.code != code) fail_msg("'%s' exited %d, expected %d: %s", args.c_str(), r.code, code, r.output.c_str());
    expect_contains(r, message);
    assert_true(r.output.find("Segmentation") == std::string::npos);
}

void test_bad_arguments(void **) {
    const Scene s = make_scene("cli_run_bad");
    const std::string base = "run" + s.images + " --out " + q(s.dir / "o");
    const std::string cc = " --calib " + q(s.k.calib_cam_to_cam("000000"));
    const std::string cvelo = " --calib-velo " + q(s.k.calib_velo_to_cam("000000"));
    const std::string v0 = " --velo0 " + q(s.k.velodyne("000000"));
    expect_failure(base + v0 + cc, s.dir, 2, "need --calib");
    expect_failure(base + v0 + cvelo, s.dir, 2, "need --calib");
    expect_failure(base + cc + cvelo, s.dir, 2, "--calib-velo is only used with");
    expect_failure(base + v0 + cc + cvelo + " --lidar0 " + q(s.k.lidar("000000", 0)), s.dir, 2, "not both");
    expect_failure(base + " --format npz", s.dir, 2, "did you mean 'npy'");
    expect_failure(base + " --format ,", s.dir, 2, "--format needs");
    expect_failure(base + " --points " + q(s.dir / "c.ply"), s.dir, 2, "--points needs --calib");
    expect_failure(base + " --velo-0 x", s.dir, 2, "did you mean --velo0");
    {
        std::ofstream(s.dir / "odd.bin", std::ios::binary) << "0123456789";
    }
    expect_failure(base + cc + cvelo + " --velo0 " + q(s.dir / "odd.bin"), s.dir, 1, "not a multiple of 16");
    expect_failure(base + cc + cvelo + " --velo1 " + q(s.dir / "none.bin"), s.dir, 1, "cannot open");
    assert_false(fs::exists(s.dir / "o" / "flow"));
}

// The rig options: --fx ... give --calib's result; a calibration of another image size is a
// warning, or an error with --strict; bad combinations exit 2, bad files 1 naming the file
// (a FIFO is refused, not waited on).
void test_rig_options(void **) {
    const Scene s = make_scene("cli_run_rig");
    const std::string base = "run" + s.images + " --stage consistency";
    const std::string cc = " --calib " + q(s.k.calib_cam_to_cam("000000"));
    char numbers[200];
    std::snprintf(numbers, sizeof numbers, " --fx %.17g --fy %.17g --cx %.17g --cy %.17g --baseline %.17g", s.cam.fx,
                  s.cam.fy, s.cam.cx, s.cam.cy, s.cam.baseline);
    for (const auto &[name, rig] : {std::pair<const char *, std::string>{"calib", cc}, {"numbers", numbers}}) {
        const Result r = run(base + rig + " --points " + q(s.dir / name / "c.ply") + " --out " + q(s.dir / name), s.dir);
        if (r.code != 0) fail_msg("%s", r.output.c_str());
    }
    for (const char *f : {"disp_0/000000_10.png", "flow/000000_10.png", "c.ply"}) {
        std::ifstream a(s.dir / "calib" / f, std::ios::binary), b(s.dir / "numbers" / f, std::ios::binary);
        const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
        assert_true(!x.empty() && x == y);
    }
    // The same file with a size: 320x96 images against 640x96.
    {
        std::ifstream in(s.k.calib_cam_to_cam("000000"));
        std::ofstream out(s.dir / "sized.txt");
        out << in.rdbuf() << "S_rect_02: 640 96\n";
    }
    const std::string sized = " --calib " + q(s.dir / "sized.txt");
    const Result warned = run(base + sized + " --out " + q(s.dir / "w"), s.dir);
    assert_int_equal(warned.code, 0);
    expect_contains(warned, "warning: the images are 320x96 but the calibration is for 640x96");
    expect_failure(base + sized + " --strict --out " + q(s.dir / "s"), s.dir, 1, "640x96 (--strict)");
    expect_failure(base + cc + " --fx 100 --out " + q(s.dir / "o"), s.dir, 2, "not both");
    expect_failure(base + " --fx 100 --cx 10 --out " + q(s.dir / "o"), s.dir, 2, "needs --fx, --cx, --cy and --baseline");
    expect_failure(base + " --fx 0 --cx 10 --cy 10 --baseline 1 --out " + q(s.dir / "o"), s.dir, 2, "fx");
    std::ofstream(s.dir / "left.yaml") << "image_width: 320\nimage_height: 96\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
                                          "  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n";
    expect_failure(base + " --calib " + q(s.dir / "left.yaml") + " --out " + q(s.dir / "o"), s.dir, 1,
                   (s.dir / "left.yaml").string() + ": a camera_info file describes one camera");
    expect_failure(base + " --calib " + q(s.dir / "left.yaml") + "," + q(s.dir / "left.yaml") + " --out " +
                       q(s.dir / "o"),
                   s.dir, 1, "left.yaml: missing key rectification_matrix");
    assert_int_equal(mkfifo((s.dir / "fifo").c_str(), 0600), 0);
    expect_failure(base + " --calib " + q(s.dir / "fifo") + " --out " + q(s.dir / "o"), s.dir, 1,
                   "fifo is not a regular file");
}

// Output names: --id, else left0's file stem (KITTI's ID_10 kept for 6-digit ids); any 8-bit
// image OpenCV reads (here JPEG) is an input; run's pictures carry their colour bars.
void test_output_names_and_jpeg_inputs(void **) {
    const Scene s = make_scene("cli_run_names");
    const std::string rest = " --right0 " + q(s.k.right("000000", 0)) + " --left1 " + q(s.k.left("000000", 1)) +
                             " --right1 " + q(s.k.right("000000", 1)) + " --stage matching";
    const fs::path jpg = s.dir / "cam0 left.jpg";
    assert_true(cv::imwrite(jpg.string(), io::read_image(s.k.left("000000", 0))));
    const fs::path out = s.dir / "o";
    Result r = run("run --left0 " + q(jpg) + rest + " --format kitti,npy --out " + q(out), s.dir);
    if (r.code != 0) fail_msg("run with a JPEG left0 failed: %s", r.output.c_str());
    for (const char *f : {"flow/cam0_left.png", "disp_0/cam0_left.png", "disp_1/cam0_left.npy", "flow/cam0_left.npy"})
        if (!fs::exists(out / f)) fail_msg("no %s: %s", f, r.output.c_str());
    expect_contains(r, "wrote     " + (out / "flow" / "cam0_left.png").string());
    // The pictures: the map on top, its legend below (disparity: a colour bar; flow: the wheel).
    for (const char *pic : {"cam0_left_disp0.png", "cam0_left_disp1.png", "cam0_left_flow.png"}) {
        const cv::Mat m = io::read_image((out / "viz" / pic).string());
        assert_true(m.rows > 96 + 30 && m.cols >= 320);
    }
    // A 6-digit stem (or id) keeps KITTI's names; another --id is used as given.
    const fs::path six = s.dir / "000123.png";
    fs::copy_file(s.k.left("000000", 0), six);
    r = run("run --left0 " + q(six) + rest + " --out " + q(out), s.dir);
    assert_int_equal(r.code, 0);
    assert_true(fs::exists(out / "flow" / "000123_10.png") && fs::exists(out / "viz" / "000123_disp0.png"));
    r = run("run --left0 " + q(s.k.left("000000", 0)) + rest + " --id 000007 --out " + q(out), s.dir);
    assert_int_equal(r.code, 0);
    assert_true(fs::exists(out / "flow" / "000007_10.png"));
    r = run("run --left0 " + q(s.k.left("000000", 0)) + rest + " --id drive_b.t3 --format flo --out " + q(out), s.dir);
    assert_int_equal(r.code, 0);
    assert_true(fs::exists(out / "flow" / "drive_b.t3.flo") && fs::exists(out / "disp_0" / "drive_b.t3.pfm"));
    // A KITTI image name gives the frame id (image_2/000000_10.png -> 000000_10.png).
    r = run("run --left0 " + q(s.k.left("000000", 0)) + rest + " --out " + q(s.dir / "k"), s.dir);
    assert_int_equal(r.code, 0);
    assert_true(fs::exists(s.dir / "k" / "flow" / "000000_10.png"));
    expect_failure("run --left0 " + q(jpg) + rest + " --id a/b --out " + q(out), s.dir, 2, "output name 'a/b'");
    const Result h = run("run --help", s.dir);
    expect_contains(h, "6 digits write ID_10.EXT");
}

// --quiet and --verbose on every sub-command.
void test_quiet_and_verbose(void **) {
    const Scene s = make_scene("cli_run_quiet");
    for (const char *cmd : {"demo", "run", "kitti", "synth", "sample-lidar", "eval", "viz", "options"}) {
        const Result h = run(std::string(cmd) + " --help", s.dir);
        assert_int_equal(h.code, 0);
        expect_contains(h, "--quiet");
        expect_contains(h, "--verbose");
        const Result bad = run(std::string(cmd) + " --quiet --verbose", s.dir);
        assert_int_equal(bad.code, 2);
        expect_contains(bad, "--quiet and --verbose exclude each other");
    }
    const std::string base = "run" + s.images + " --stage matching --out " + q(s.dir / "o");
    Result r = run(base + " --quiet", s.dir);
    assert_int_equal(r.code, 0);
    if (!r.output.empty()) fail_msg("run --quiet said: %s", r.output.c_str());
    assert_true(fs::exists(s.dir / "o" / "flow" / "000000_10.png"));
    // Errors still come through.
    r = run(base + " --quiet --format npz", s.dir);
    assert_int_equal(r.code, 2);
    expect_contains(r, "did you mean 'npy'");
    r = run(base + " --verbose", s.dir);
    assert_int_equal(r.code, 0);
    expect_contains(r, "run: preset default");
    expect_contains(r, "run: inputs read in ");
    expect_contains(r, "lidarflow run: finished in ");
    const std::string kitti = "kitti --root " + q(s.root) + " --stage matching --no-viz --lidar none";
    r = run(kitti + " --quiet", s.dir);
    assert_int_equal(r.code, 0);
    if (!r.output.empty()) fail_msg("kitti --quiet said: %s", r.output.c_str());
    r = run(kitti + " --verbose", s.dir);
    assert_int_equal(r.code, 0);
    expect_contains(r, "kitti:   000000: loading took ");
    r = run("synth --quiet --out " + q(s.dir / "k2") + " --width 160 --height 64", s.dir);
    assert_int_equal(r.code, 0);
    assert_true(r.output.empty());
}

}  // namespace

// Whether `strip` holds the colour c somewhere.
bool holds(const cv::Mat &strip, cv::Vec3b c) {
    for (int y = 0; y < strip.rows; ++y)
        for (int x = 0; x < strip.cols; ++x)
            if (strip.at<cv::Vec3b>(y, x) == c) return true;
    return false;
}

// kitti --out pictures carry legends below the map (320x96 here): error maps the ten bands of
// the log scale with the threshold in white, disparities a bar from the colour of 0 to that of
// its maximum, flow a colour wheel; and the library's messages come with --verbose.
void test_kitti_pictures_have_legends(void **) {
    const Scene s = make_scene("cli_kitti_legends");
    const fs::path out = s.dir / "k";
    const Result r = run("kitti --root " + q(s.root) + " --lidar velodyne --stage sparse --verbose --out " + q(out), s.dir);
    if (r.code != 0) fail_msg("kitti --out failed: %s", r.output.c_str());
    expect_contains(r, "lidarflow: info: 4 of 16 LiDAR points dropped: 2 behind the camera (z <= 0.1 m), 2 outside the 320x96 image");
    const std::string base = (out / "viz" / "000000").string();
    for (const char *kind : {"_disp0_error", "_disp1_error", "_flow_error"}) {
        const cv::Mat p = cv::imread(base + kind + ".png", cv::IMREAD_COLOR);
        if (p.empty()) fail_msg("no picture %s", kind);
        assert_true(p.cols >= 320 && p.rows > 96 + 30);
        const cv::Mat strip = p(cv::Rect(0, 96, p.cols, p.rows - 96));
        for (double n : {0.0, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1.0, 2.0, 4.0, 8.0, 16.0})
            if (!holds(strip, viz::log_error_color(n))) fail_msg("%s: band from %g not in the legend", kind, n);
        assert_true(holds(strip, cv::Vec3b(255, 255, 255)));  // the outlier threshold
    }
    for (const char *kind : {"_disp0", "_disp1"}) {
        const cv::Mat p = cv::imread(base + kind + ".png", cv::IMREAD_COLOR);
        if (p.empty()) fail_msg("no picture %s", kind);
        assert_true(p.cols >= 320 && p.rows > 96 + 20);
        const cv::Mat strip = p(cv::Rect(0, 96, p.cols, p.rows - 96));
        assert_true(holds(strip, viz::disparity_color(0, 1)) && holds(strip, viz::disparity_color(1, 1)));
    }
    const cv::Mat flow = cv::imread(base + "_flow.png", cv::IMREAD_COLOR);
    assert_true(!flow.empty() && flow.rows > 96 + 20);
    // The wheel: many hues below the map.
    const cv::Mat strip = flow(cv::Rect(0, 96, flow.cols, flow.rows - 96));
    std::vector<int> hues(256, 0);
    cv::Mat hsv;
    cv::cvtColor(strip, hsv, cv::COLOR_BGR2HSV_FULL);
    int distinct = 0;
    for (int y = 0; y < hsv.rows; ++y)
        for (int x = 0; x < hsv.cols; ++x) {
            const cv::Vec3b h = hsv.at<cv::Vec3b>(y, x);
            if (h[1] > 60 && !hues[h[0]]++) ++distinct;
        }
    assert_true(distinct > 100);
}

int main() {
    const char *cli = std::getenv("LIDARFLOW_CLI");
    if (!cli || !*cli || !fs::exists(cli)) {
        std::printf("run_cli: skipped: LIDARFLOW_CLI is not set to the built lidarflow binary\n");
        return 77;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_velodyne_inputs),
        cmocka_unit_test(test_formats_and_points),
        cmocka_unit_test(test_points_object_motion),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_rig_options),
        cmocka_unit_test(test_output_names_and_jpeg_inputs),
        cmocka_unit_test(test_quiet_and_verbose),
        cmocka_unit_test(test_kitti_pictures_have_legends),
    };
    return cmocka_run_group_tests_name("run_cli", tests, nullptr, nullptr);
}
