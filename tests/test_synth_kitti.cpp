// SPDX-License-Identifier: MIT
// write_kitti: the synthetic scene in the KITTI layout reads back (io::read_*) as the
// in-memory ground truth to PNG precision, with the calibration and the extra LiDAR/mask files.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "synth/scene.hpp"
#include "synth/write_kitti.hpp"
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

synth::SynthScene small_scene() {
    synth::SynthConfig c;
    c.seed = 11;
    c.width = 320;
    c.height = 96;
    return synth::render(c);
}

// PNG keeps floor(256 d) / 256 (and 1/256 for a valid 0): never above d, less than 1/256 below.
void check_disparity(const DisparityMap &mem, const DisparityMap &file) {
    assert_true(mem.size() == file.size());
    size_t valid = 0;
    for (int y = 0; y < mem.rows; ++y)
        for (int x = 0; x < mem.cols; ++x) {
            const float a = mem(y, x), b = file(y, x);
            assert_int_equal(disparity_valid(a), disparity_valid(b));
            if (!disparity_valid(a)) continue;
            ++valid;
            assert_true(b <= a + 1e-6f && a - b < 1.0f / 256 + 1e-6f);
        }
    assert_true(valid > 0);
}

void check_flow(const FlowField &mem, const FlowField &file) {
    assert_true(mem.u.size() == file.u.size());
    for (int y = 0; y < mem.height(); ++y)
        for (int x = 0; x < mem.width(); ++x) {
            assert_int_equal(mem.valid(y, x) != 0, file.valid(y, x) != 0);
            if (!mem.valid(y, x)) continue;
            assert_true(std::fabs(mem.u(y, x) - file.u(y, x)) < 1.0f / 64 + 1e-6f);
            assert_true(std::fabs(mem.v(y, x) - file.v(y, x)) < 1.0f / 64 + 1e-6f);
        }
}

bool identical(const cv::Mat &a, const cv::Mat &b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a.reshape(1), b.reshape(1), cv::NORM_INF) == 0;
}

void test_write_then_read_back(void **) {
    const synth::SynthScene s = small_scene();
    const fs::path root = test::scratch_dir("synth_kitti_roundtrip");
    synth::write_kitti(s, root.string(), "000042");
    const io::KittiLayout k{root.string()};

    assert_true(identical(io::read_image(k.left("000042", 0)), s.left0));
    assert_true(identical(io::read_image(k.left("000042", 1)), s.left1));
    assert_true(identical(io::read_image(k.right("000042", 0)), s.right0));
    assert_true(identical(io::read_image(k.right("000042", 1)), s.right1));

    check_disparity(s.disp0_occ, io::read_disparity_png(k.gt_disp0("000042", true)));
    check_disparity(s.disp0_noc, io::read_disparity_png(k.gt_disp0("000042", false)));
    check_disparity(s.disp1_occ, io::read_disparity_png(k.gt_disp1("000042", true)));
    check_disparity(s.disp1_noc, io::read_disparity_png(k.gt_disp1("000042", false)));
    check_flow(s.flow_occ, io::read_flow_png(k.gt_flow("000042", true)));
    check_flow(s.flow_noc, io::read_flow_png(k.gt_flow("000042", false)));

    check_disparity(s.lidar0.to_map(), io::read_disparity_png(k.lidar("000042", 0)));
    check_disparity(s.lidar1.to_map(), io::read_disparity_png(k.lidar("000042", 1)));
    assert_int_equal(SparseLidar::from_map(io::read_disparity_png(k.lidar("000042", 1))).points.size(),
                     s.lidar1.points.size());

    assert_true(identical(io::read_image(synth::textureless_mask_path(root.string(), "000042")), s.textureless_mask));
    assert_true(identical(io::read_image(synth::shadow_mask_path(root.string(), "000042")), s.shadow_mask));

    const io::CamToCamCalib calib = io::read_calib_cam_to_cam(k.calib_cam_to_cam("000042"));
    assert_true(std::fabs(calib.camera.fx - s.camera.fx) < 1e-9 * s.camera.fx);
    assert_true(std::fabs(calib.camera.cx - s.camera.cx) < 1e-9 * s.camera.fx);
    assert_true(std::fabs(calib.camera.cy - s.camera.cy) < 1e-9 * s.camera.fx);
    assert_true(std::fabs(calib.camera.baseline - s.camera.baseline) < 1e-9);

    const auto ids = k.frame_ids();
    assert_int_equal(ids.size(), 1);
    assert_string_equal(ids[0].c_str(), "000042");
}

void test_bad_id_or_destination(void **) {
    const synth::SynthScene s = small_scene();
    const fs::path root = test::scratch_dir("synth_kitti_bad");
    for (const char *id : {"", "42", "00004a", "0000420", "../x00"}) {
        try {
            synth::write_kitti(s, root.string(), id);
            fail_msg("id '%s' was accepted", id);
        } catch (const Error &e) {
            assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::InvalidArgument));
        }
    }
    assert_true(fs::is_empty(root));
    // A regular file where a folder must go: Io, not a crash.
    const fs::path blocker = root / "file";
    std::FILE *f = std::fopen(blocker.c_str(), "w");
    assert_non_null(f);
    std::fclose(f);
    try {
        synth::write_kitti(s, blocker.string(), "000000");
        fail_msg("writing below a regular file succeeded");
    } catch (const Error &e) {
        assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::Io));
    }
    try {
        synth::write_kitti(synth::SynthScene{}, root.string(), "000000");
        fail_msg("an empty scene was written");
    } catch (const Error &e) {
        assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::InvalidArgument));
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_write_then_read_back),
        cmocka_unit_test(test_bad_id_or_destination),
    };
    return cmocka_run_group_tests_name("synth_kitti", tests, nullptr, nullptr);
}
