// SPDX-License-Identifier: MIT
// The camera trajectory of `lidarflow sequence` against `synth --drive`'s gt/poses.txt on a
// 10-frame drive (5 under the sanitizers) at KITTI's image size (1242x375; at 640x192 the
// realtime preset's forward translation is some 3 % short, at this size well within the bound):
//  - gt/poses.txt: one KITTI odometry line per frame, frame 0 the identity;
//  - poses.txt (realtime preset): the end point within 2 % of the path length of the truth;
//  - --skip-existing --poses tum: every pair skipped, the trajectory rebuilt from the manifests'
//    ego-motions, in TUM format (the drive's times, unit quaternions of the same rotations);
//  - --frames A:B writes poses_A-B.txt, frame A the origin.
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/sanitizers.hpp"

#include "io/poses.hpp"
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

// Under the sanitizers (4x slower, there for memory errors) a shorter drive: 5 frames.
constexpr int kFrames = LIDARFLOW_SANITIZED ? 5 : 10;
const std::string kPairs = std::to_string(kFrames - 1) + " pairs: ";

void expect_run(const test::CliRun &r, int code, const std::string &what) {
    if (r.code == code && r.output.find(what) != std::string::npos) return;
    std::printf("%s", r.output.c_str());
    fail_msg("expected exit %d and \"%s\" in the output above, got exit %d", code, what.c_str(), r.code);
}

cv::Vec3d centre(const cv::Matx34d &P) { return {P(0, 3), P(1, 3), P(2, 3)}; }

std::vector<std::vector<double>> rows(const fs::path &p) {
    std::ifstream in(p);
    std::vector<std::vector<double>> out;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream f(line);
        std::vector<double> v;
        double x;
        while (f >> x) v.push_back(x);
        out.push_back(v);
    }
    return out;
}

void test_trajectory_against_ground_truth(void **) {
    const fs::path dir = test::scratch_dir("sequence_poses"), drive = dir / "drive", out = dir / "out";
    expect_run(test::run_cli("synth --drive " + test::quoted(drive) + " --frames " + std::to_string(kFrames) +
                             " --width 1242 --height 375 --seed 4"),
               0, "wrote a drive of " + std::to_string(kFrames) + " frames");
    const std::vector<cv::Matx34d> gt = io::read_kitti_poses((drive / "gt/poses.txt").string());
    assert_int_equal(gt.size(), kFrames);
    assert_true(cv::norm(gt[0] - cv::Matx34d::eye()) == 0);

    const std::string base = "sequence --drive " + test::quoted(drive) + " --out " + test::quoted(out) +
                             " --preset realtime --format npy --threads 2";
    expect_run(test::run_cli(base), 0, kPairs + std::to_string(kFrames - 1) + " computed");
    const std::vector<cv::Matx34d> est = io::read_kitti_poses((out / "poses.txt").string());
    assert_int_equal(est.size(), kFrames);
    assert_true(cv::norm(est[0] - cv::Matx34d::eye()) == 0);
    double path = 0;
    for (int k = 1; k < kFrames; ++k) path += cv::norm(centre(gt[k]) - centre(gt[k - 1]));
    const double end_error = cv::norm(centre(est.back()) - centre(gt.back()));
    std::printf("end point %.3f m off after %.2f m (%.2f %%)\n", end_error, path, 100 * end_error / path);
    assert_true(path > 0.55 * (kFrames - 1));
    assert_true(end_error < 0.02 * path);

    // From the manifests alone, in TUM format.
    expect_run(test::run_cli(base + " --skip-existing --poses tum"), 0, kPairs + "0 computed, " + std::to_string(kFrames - 1) + " skipped");
    const std::vector<std::vector<double>> tum = rows(out / "poses.txt");
    assert_int_equal(tum.size(), kFrames);
    for (int k = 0; k < kFrames; ++k) {
        const std::vector<double> &r = tum[static_cast<size_t>(k)];
        assert_int_equal(r.size(), 8);
        if (k > 0) assert_true(std::fabs(r[0] - tum[static_cast<size_t>(k - 1)][0] - 0.1) < 1e-6);  // 10 Hz times
        assert_true(cv::norm(cv::Vec3d(r[1], r[2], r[3]) - centre(est[static_cast<size_t>(k)])) < 1e-6);
        const double x = r[4], y = r[5], z = r[6], w = r[7];
        assert_true(std::fabs(x * x + y * y + z * z + w * w - 1) < 1e-6);
        const cv::Matx33d R(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y));
        assert_true(cv::norm(R - est[static_cast<size_t>(k)].get_minor<3, 3>(0, 0)) < 1e-6);
    }

    // A part of the drive: its own file, its first frame the origin.
    expect_run(test::run_cli(base + " --skip-existing --frames 1:4"), 0, "3 pairs: 0 computed, 3 skipped");
    const std::vector<cv::Matx34d> part = io::read_kitti_poses((out / "poses_0000000001-0000000004.txt").string());
    assert_int_equal(part.size(), 4);
    assert_true(cv::norm(part[0] - cv::Matx34d::eye()) == 0);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_trajectory_against_ground_truth),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
