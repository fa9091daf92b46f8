// SPDX-License-Identifier: MIT
// `lidarflow sample-lidar`: runs the built CLI ($LIDARFLOW_CLI) on the real frames and with bad
// arguments, and checks exit codes, the files written and their contents.
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
// cmocka.h defines fail(), which breaks <ios>, and its 1.1.5 header lacks extern "C": include
// it last, wrapped (test_support.hpp's own include is then a no-op).
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

std::string cli_or_skip() {
    const char *cli = std::getenv("LIDARFLOW_CLI");
    if (!cli || !*cli || !fs::exists(cli)) {
        std::printf("LIDARFLOW_CLI is not set to the built lidarflow program: skipped\n");
        return "";
    }
    return cli;
}

// Runs `cli sample-lidar args`, output into `log`; returns the exit code (-1 if it did not exit).
int run(const std::string &cli, const std::string &args, const fs::path &log, std::string *output = nullptr) {
    const std::string cmd = "'" + cli + "' sample-lidar " + args + " > '" + log.string() + "' 2>&1";
    const int st = std::system(cmd.c_str());
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    std::printf("$ lidarflow sample-lidar %s\n%s", args.c_str(), ss.str().c_str());
    if (output) *output = ss.str();
    return st != -1 && WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

int valid_count(const DisparityMap &d) { return cv::countNonZero(d >= 0); }

void test_bad_arguments(void **) {
    const std::string cli = cli_or_skip();
    if (cli.empty()) skip();
    const fs::path dir = test::scratch_dir("cli_sample_lidar_bad");
    const fs::path log = dir / "log.txt";
    const std::string out = " --out '" + (dir / "out").string() + "'";
    const std::string nowhere = " --root '" + (dir / "no_such_root").string() + "'";
    assert_int_equal(run(cli, "", log), 2);                                                   // --root missing
    assert_int_equal(run(cli, nowhere + out + " --protocol lidar", log), 2);                 // unknown protocol
    assert_int_equal(run(cli, nowhere + out + " --protocol paper --beams 16", log), 2);      // beams: velodyne only
    assert_int_equal(run(cli, nowhere + out + " --protocol paper --points many", log), 2);   // not a number
    assert_int_equal(run(cli, nowhere + out + " --protocol paper --points 0", log), 2);
    assert_int_equal(run(cli, nowhere + out + " --protocol velodyne --beams 0", log), 2);
    assert_int_equal(run(cli, nowhere + out + " --protocol paper --step 3", log), 2);        // below the window
    assert_int_equal(run(cli, nowhere + out + " --protocol paper --frobnicate", log), 2);
    assert_int_equal(run(cli, nowhere + " --protocol paper", log), 2);                       // --out missing
    assert_int_equal(run(cli, nowhere + out + " --protocol paper", log), 1);                 // Io: no such root
    assert_false(fs::exists(dir / "out" / "lidar_0"));
}

void test_paper_protocol_files(void **) {
    // cmocka's skip() longjmps past destructors: decide before any string holds heap memory.
    if (test::kitti_dir().empty() || cli_or_skip().empty()) {
        if (test::kitti_dir().empty()) std::printf("KITTI frames not available (LIDARFLOW_KITTI_DIR): skipped\n");
        skip();
    }
    const std::string cli = cli_or_skip(), root = test::kitti_dir();
    const fs::path dir = test::scratch_dir("cli_sample_lidar_paper");
    const io::KittiLayout in{root}, out{(dir / "out").string()};
    std::string text;
    assert_int_equal(run(cli, "--root '" + root + "' --protocol paper --out '" + out.root + "'", dir / "log.txt", &text), 0);
    assert_true(text.find("step") != std::string::npos && text.find("mean") != std::string::npos);
    const auto ids = in.frame_ids();  // --ids defaults to every frame
    double n0 = 0, n1 = 0;
    for (const std::string &id : ids) {
        assert_true(text.find(id) != std::string::npos);
        const DisparityMap l0 = io::read_disparity_png(out.lidar(id, 0)), l1 = io::read_disparity_png(out.lidar(id, 1));
        const DisparityMap gt0 = io::read_disparity_png(in.gt_disp0(id));
        assert_true(l0.size() == gt0.size() && l1.size() == gt0.size());
        n0 += valid_count(l0) / static_cast<double>(ids.size());
        n1 += valid_count(l1) / static_cast<double>(ids.size());
        // Ground truth is stored in 1/256 steps, so the written samples are the GT values exactly.
        for (int y = 0; y < l0.rows; ++y)
            for (int x = 0; x < l0.cols; ++x)
                if (disparity_valid(l0(y, x))) assert_true(l0(y, x) == gt0(y, x));
    }
    std::printf("mean written: lidar_0 %.1f, lidar_1 %.1f points\n", n0, n1);
    assert_true(n0 >= 70 && n0 <= 110 && n1 >= 70 && n1 <= 110);

    // --ids picks frames; --step fixes the grid.
    const fs::path one = dir / "one";
    assert_int_equal(run(cli, "--root '" + root + "' --ids " + ids.front() + " --protocol paper --step 30 --out '" +
                                  one.string() + "'", dir / "log2.txt", &text),
                     0);
    const auto row = text.find(ids.front() + " ");
    assert_true(row != std::string::npos);
    const std::string line = text.substr(row, text.find('\n', row) - row);
    assert_true(line.size() > 3 && line.compare(line.size() - 3, 3, " 30") == 0);  // the step column
    assert_int_equal(std::distance(fs::directory_iterator(one / "lidar_0"), fs::directory_iterator()), 1);
}

void test_velodyne_protocol_files(void **) {
    // cmocka's skip() longjmps past destructors: decide before any string holds heap memory.
    if (test::kitti_dir().empty() || cli_or_skip().empty()) {
        if (test::kitti_dir().empty()) std::printf("KITTI frames not available (LIDARFLOW_KITTI_DIR): skipped\n");
        skip();
    }
    const std::string cli = cli_or_skip(), root = test::kitti_dir();
    const fs::path dir = test::scratch_dir("cli_sample_lidar_velodyne");
    const io::KittiLayout in{root}, out{(dir / "out").string()};
    std::string text;
    const std::string id = in.frame_ids().back();
    assert_int_equal(run(cli, "--root '" + root + "' --ids " + id + " --protocol velodyne --beams 32 --points 200 --out '" +
                                  out.root + "'", dir / "log.txt", &text),
                     0);
    assert_true(text.find("all-invalid") != std::string::npos);
    const DisparityMap l0 = io::read_disparity_png(out.lidar(id, 0)), l1 = io::read_disparity_png(out.lidar(id, 1));
    assert_true(valid_count(l0) >= 170 && valid_count(l0) <= 230);
    assert_int_equal(valid_count(l1), 0);
    assert_true(l1.size() == l0.size() && l0.size() == io::read_image(in.left(id, 0)).size());
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_paper_protocol_files),
        cmocka_unit_test(test_velodyne_protocol_files),
    };
    return cmocka_run_group_tests_name("cli_sample_lidar", tests, nullptr, nullptr);
}
