// SPDX-License-Identifier: MIT
// The synth, viz and demo commands of the lidarflow CLI: files they write, what demo says,
// and non-zero exits on bad arguments. Runs the built binary ($LIDARFLOW_CLI, set by CTest).
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/maps.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "synth/write_kitti.hpp"
#include "viz/error_map.hpp"
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

void expect_kitti_frame(const fs::path &root, const std::string &id) {
    const io::KittiLayout k{root.string()};
    for (const std::string &f :
         {k.left(id, 0), k.left(id, 1), k.right(id, 0), k.right(id, 1), k.gt_disp0(id, true), k.gt_disp0(id, false),
          k.gt_disp1(id, true), k.gt_disp1(id, false), k.gt_flow(id, true), k.gt_flow(id, false),
          k.calib_cam_to_cam(id), k.lidar(id, 0), k.lidar(id, 1), synth::textureless_mask_path(root.string(), id),
          synth::shadow_mask_path(root.string(), id)}) {
        if (!fs::is_regular_file(f)) fail_msg("missing %s", f.c_str());
        assert_true(fs::file_size(f) > 0);
    }
}

void test_demo_writes_layout_and_pictures(void **) {
    const fs::path dir = test::scratch_dir("cli_demo");
    const Result r = run("demo --out " + q(dir / "out"), dir);
    if (r.code != 0) fail_msg("demo failed (%d): %s", r.code, r.output.c_str());
    expect_kitti_frame(dir / "out", "000000");
    for (const char *name : {"inputs", "flow_gt", "flow_coverage", "disp0_gt", "disp1_gt", "masks"}) {
        const fs::path p = dir / "out" / "viz" / (std::string("000000_") + name + ".png");
        const cv::Mat m = io::read_image(p.string());
        assert_int_equal(m.type(), CV_8UC3);
        // Every picture carries its key in a strip below it: the LiDAR dots' disparity bar, the
        // flow wheel, the disparity bar, the names of the coverage's and the masks' colours.
        if (std::string(name) == "inputs") {
            assert_int_equal(m.cols, 2 * 640 + 4);  // 2x2 grid with a 4 px gutter
            assert_true(m.rows >= 2 * 192 + 4 + 40);
        } else {
            assert_int_equal(m.cols, 640);
            assert_true(m.rows >= 192 + 40);
        }
        assert_true(r.output.find(p.string()) != std::string::npos);  // it says what it wrote
    }
    // The estimator ran with and without LiDAR: both results and their pictures are written,
    // and the score table names both rows.
    for (const char *run_name : {"lidarflow", "image-only"}) {
        const fs::path est = dir / "out" / run_name;
        const DisparityMap d0 = io::read_disparity_png((est / "disp_0" / "000000_10.png").string());
        assert_int_equal(d0.cols, 640);
        assert_int_equal(d0.rows, 192);
        assert_int_equal(cv::countNonZero(d0 >= 0), 640 * 192);  // the final stage is dense
        for (const char *pic : {"flow", "disp0", "disp0_error", "flow_error"}) {
            const fs::path p = dir / "out" / "viz" / (std::string("000000_") + run_name + "_" + pic + ".png");
            const cv::Mat m = io::read_image(p.string());
            assert_int_equal(m.cols, 640);
            // Error maps carry the log scale's legend below the map, the others the wheel or bar.
            assert_true(m.rows >= 192 + 40);
        }
        assert_true(r.output.find(std::string("  ") + run_name + " ") != std::string::npos);
    }
    assert_true(r.output.find("hard regions") != std::string::npos);
    assert_true(r.output.find("88 points at t0") != std::string::npos);
    // Default output folder is demo-out in the working directory.
    const Result h = run("demo --help", dir);
    assert_int_equal(h.code, 0);
    assert_true(h.output.find("demo-out") != std::string::npos);
}

void test_synth_frames_ids_and_options(void **) {
    const fs::path dir = test::scratch_dir("cli_synth");
    const fs::path out = dir / "kitti";
    Result r = run("synth --out " + q(out) + " --frames 2 --seed 5 --width 320 --height 96 --points 40", dir);
    if (r.code != 0) fail_msg("synth failed (%d): %s", r.code, r.output.c_str());
    expect_kitti_frame(out, "000000");
    expect_kitti_frame(out, "000001");
    const io::KittiLayout k{out.string()};
    const cv::Mat a = io::read_image(k.left("000000", 0)), b = io::read_image(k.left("000001", 0));
    assert_int_equal(a.cols, 320);
    assert_int_equal(a.rows, 96);
    assert_true(cv::norm(a, b, cv::NORM_L1) > 0);  // frame k uses seed + k
    assert_int_equal(SparseLidar::from_map(io::read_disparity_png(k.lidar("000001", 0))).points.size(), 40);
    r = run("synth --out " + q(out) + " --id 000010 --seed 5 --width 320 --height 96", dir);
    assert_int_equal(r.code, 0);
    expect_kitti_frame(out, "000010");
    // Same seed and size as frame 000000 above: identical image files.
    assert_true(cv::norm(a, io::read_image(k.left("000010", 0)), cv::NORM_INF) == 0);
    assert_int_equal(k.frame_ids().size(), 3);
}

void test_viz_pictures_and_error_maps(void **) {
    const fs::path dir = test::scratch_dir("cli_viz");
    const fs::path out = dir / "kitti";
    assert_int_equal(run("synth --out " + q(out) + " --width 320 --height 96", dir).code, 0);
    const io::KittiLayout k{out.string()};
    Result r = run("viz --disp " + q(k.gt_disp0("000000")) + " --out " + q(dir / "d.png") + " --max 60 --no-legend",
                   dir);
    if (r.code != 0) fail_msg("viz --disp failed: %s", r.output.c_str());
    cv::Mat m = io::read_image((dir / "d.png").string());
    assert_int_equal(m.type(), CV_8UC3);
    assert_true(m.size() == cv::Size(320, 96));
    // With the legend (the default) the map is unchanged on top and a strip is added below.
    r = run("viz --disp " + q(k.gt_disp0("000000")) + " --out " + q(dir / "dl.png") + " --max 60", dir);
    assert_int_equal(r.code, 0);
    const cv::Mat with_legend = io::read_image((dir / "dl.png").string());
    assert_true(with_legend.cols >= 320);  // a narrow map is widened to fit the scale
    assert_true(with_legend.rows > 96 + 20);
    assert_int_equal(cv::norm(with_legend(cv::Rect(0, 0, 320, 96)), m, cv::NORM_INF), 0);

    r = run("viz --flow " + q(k.gt_flow("000000")) + " --out " + q(dir / "f.png") + " --style middlebury --no-legend",
            dir);
    assert_int_equal(r.code, 0);
    assert_true(io::read_image((dir / "f.png").string()).size() == cv::Size(320, 96));
    // Over the camera image: pixels without flow show the image dimmed, so the picture differs
    // from the bare colour map exactly there.
    r = run("viz --flow " + q(k.gt_flow("000000")) + " --image " + q(k.left("000000", 0)) + " --out " +
                q(dir / "fi.png") + " --style middlebury --no-legend",
            dir);
    assert_int_equal(r.code, 0);
    assert_true(io::read_image((dir / "fi.png").string()).size() == cv::Size(320, 96));
    r = run("viz --flow " + q(k.gt_flow("000000")) + " --out " + q(dir / "fw.png"), dir);
    assert_int_equal(r.code, 0);
    assert_true(io::read_image((dir / "fw.png").string()).rows > 96 + 40);  // the wheel's strip

    // Error map of the GT against itself: every pixel with GT is in the lowest band, the rest
    // black; against the noc GT (a worse "estimate" at occluded pixels) higher bands appear.
    r = run("viz --flow " + q(k.gt_flow("000000")) + " --gt " + q(k.gt_flow("000000")) + " --out " +
                q(dir / "e.png"),
            dir);
    assert_int_equal(r.code, 0);
    m = io::read_image((dir / "e.png").string());
    const cv::Vec3b lowest = viz::log_error_color(0), black(0, 0, 0);
    const FlowField gt = io::read_flow_png(k.gt_flow("000000"));
    // The map on top, its legend (the log scale) below.
    assert_true(m.rows > gt.height() + 40 && m.cols >= gt.width());
    for (int y = 0; y < gt.height(); ++y)
        for (int x = 0; x < gt.width(); ++x) assert_true(m.at<cv::Vec3b>(y, x) == (gt.valid(y, x) ? lowest : black));
    r = run("viz --flow " + q(k.gt_flow("000000")) + " --gt " + q(k.gt_flow("000000")) + " --no-legend --out " +
                q(dir / "en.png"),
            dir);
    assert_int_equal(r.code, 0);
    assert_true(io::read_image((dir / "en.png").string()).size() == cv::Size(320, 96));
    r = run("viz --disp " + q(k.gt_disp1("000000", false)) + " --gt " + q(k.gt_disp1("000000", true)) +
                " --gt-noc " + q(k.gt_disp1("000000", false)) + " --out " + q(dir / "e1.png"),
            dir);
    assert_int_equal(r.code, 0);
    m = io::read_image((dir / "e1.png").string());
    const cv::Vec3b worst_half(38 / 2, 0, 165 / 2);  // invalid estimate at occluded-only pixels
    int worst = 0;
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x) worst += m.at<cv::Vec3b>(y, x) == worst_half;
    assert_true(worst > 100);
}

void expect_failure(const std::string &args, const fs::path &dir, int code);

// `kitti` on rendered frames: options by key (--set), several seeds summarised (--seeds), and
// other placements of the paper protocol's grids (--placements).
void test_kitti_set_and_seeds(void **) {
    const fs::path dir = test::scratch_dir("cli_kitti_seeds");
    const fs::path root = dir / "kitti";
    assert_int_equal(run("synth --out " + q(root) + " --width 320 --height 96", dir).code, 0);
    const std::string base = "kitti --root " + q(root) + " --stage matching --no-viz";
    Result r = run(base + " --seeds 2 --set matching.min_coarsest_height=16,matching.iterations=2", dir);
    if (r.code != 0) fail_msg("kitti --seeds failed (%d): %s", r.code, r.output.c_str());
    assert_true(r.output.find("Over 2 seeds") != std::string::npos);
    assert_true(r.output.find("Matching: LiDAR-Flow") != std::string::npos);
    expect_failure(base + " --set matching.iterations=0", dir, 2);   // out of bounds
    expect_failure(base + " --set matching.nope=1", dir, 2);         // unknown key
    expect_failure(base + " --set matching.iterations", dir, 2);     // no value
    expect_failure(base + " --seeds 0", dir, 2);

    r = run(base + " --placements 3 --set matching.min_coarsest_height=16,matching.iterations=2", dir);
    if (r.code != 0) fail_msg("kitti --placements failed (%d): %s", r.code, r.output.c_str());
    assert_true(r.output.find("Over 1 seed(s) x 3 LiDAR placements") != std::string::npos);
    expect_failure(base + " --placements 0", dir, 2);
    expect_failure(base + " --lidar velodyne --placements 2", dir, 2);  // a real scan has no grid
}

void expect_failure(const std::string &args, const fs::path &dir, int code) {
    const Result r = run(args, dir);
    if (r.code != code) fail_msg("'%s' exited %d (want %d): %s", args.c_str(), r.code, code, r.output.c_str());
    assert_true(r.output.find("error") != std::string::npos);
}

void test_bad_arguments_fail(void **) {
    const fs::path dir = test::scratch_dir("cli_synth_bad");
    const std::string o = " --out " + q(dir / "o");
    expect_failure("synth", dir, 2);                       // --out missing
    expect_failure("synth" + o + " --width -5", dir, 2);   // render() range check
    expect_failure("synth" + o + " --height 10", dir, 2);
    expect_failure("synth" + o + " --points -1", dir, 2);
    expect_failure("synth" + o + " --noise nan", dir, 2);
    expect_failure("synth" + o + " --seed -3", dir, 2);
    expect_failure("synth" + o + " --id 12", dir, 2);
    expect_failure("synth" + o + " --id 999999 --frames 2", dir, 2);
    expect_failure("synth" + o + " --frames 0", dir, 2);
    expect_failure("synth" + o + " --bogus 1", dir, 2);
    expect_failure("synth" + o + " stray", dir, 2);
    expect_failure("synth --drive '' --frames 2", dir, 2);  // not the filesystem's root
    assert_false(fs::exists(dir / "o"));  // nothing written on bad arguments
    expect_failure("demo --seed abc" + o, dir, 2);
    expect_failure("viz --out x.png", dir, 2);  // neither --disp nor --flow
    expect_failure("viz --disp a.png --flow b.png --out x.png", dir, 2);
    expect_failure("viz --disp a.png", dir, 2);  // --out missing
    expect_failure("viz --disp a.png --gt b.png --max 3 --out x.png", dir, 2);
    expect_failure("viz --disp a.png --style kitti --out x.png", dir, 2);
    expect_failure("viz --disp a.png --points b.ply --out x.png", dir, 2);
    expect_failure("viz --disp a.png --range 30 --out x.png", dir, 2);  // --range: --points only
    expect_failure("viz --points " + q(dir / "missing.ply") + " --out " + q(dir / "x.png"), dir, 1);
    expect_failure("viz --disp " + q(dir / "missing.png") + " --out " + q(dir / "x.png"), dir, 1);  // Io
    {
        std::ofstream(dir / "junk.png") << "not a png";
    }
    expect_failure("viz --flow " + q(dir / "junk.png") + " --out " + q(dir / "x.png"), dir, 1);  // Format
    expect_failure("viz --points " + q(dir / "junk.png") + " --out " + q(dir / "x.png"), dir, 1);  // not a PLY
    assert_false(fs::exists(dir / "x.png"));
}

}  // namespace

int main() {
    const char *cli = std::getenv("LIDARFLOW_CLI");
    if (!cli || !*cli || !fs::exists(cli)) {
        std::printf("synth_cli: skipped: LIDARFLOW_CLI is not set to the built lidarflow binary\n");
        return 77;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_demo_writes_layout_and_pictures),
        cmocka_unit_test(test_synth_frames_ids_and_options),
        cmocka_unit_test(test_viz_pictures_and_error_maps),
        cmocka_unit_test(test_bad_arguments_fail),
        cmocka_unit_test(test_kitti_set_and_seeds),
    };
    return cmocka_run_group_tests_name("synth_cli", tests, nullptr, nullptr);
}
