// SPDX-License-Identifier: MIT
// `lidarflow eval` end to end on a small synthetic KITTI folder written here (always runs) and,
// when LIDARFLOW_KITTI_DIR is set, on the real frames: the ground truth submitted as its own
// estimate scores 0.00; outliers planted in an estimate are counted; missing files and bad
// options fail with a clear message; --json writes well-formed JSON (read back with nlohmann-json;
// tests/test_eval_json.cpp checks the report's values).
#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "core/error.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
// cmocka.h defines fail(), which breaks <ios>: include it after every C++ header. Its 1.1.5
// header has no extern "C" of its own, so wrap it here (test_support.hpp's include is then a no-op).
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

using Run = test::CliRun;

Run run_cli(const std::string &args) { return test::run_cli("eval " + args); }

std::string slurp(const fs::path &p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

bool contains(const std::string &s, const std::string &what) { return s.find(what) != std::string::npos; }

void expect_contains(const std::string &s, const std::string &what) {
    if (contains(s, what)) return;
    std::printf("%s", s.c_str());  // cmocka truncates long failure messages
    fail_msg("expected \"%s\" in the output above", what.c_str());
}

// Well-formed JSON (nlohmann-json rejects NaN/inf tokens too) with the report's format tag.
void expect_wellformed_json(const std::string &j) {
    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(j);
    } catch (const nlohmann::json::parse_error &e) {
        std::printf("%s", j.c_str());
        fail_msg("not JSON: %s", e.what());
    }
    assert_true(doc.is_object());
    assert_true(doc["format"] == "lidarflow-eval/1");
}

constexpr int W = 24, H = 16;

// Ground truth of a synthetic frame with holes; noc has extra holes.
void write_synthetic_gt(const std::string &root, const std::string &id, int seed) {
    const io::KittiLayout k{root};
    DisparityMap d0(H, W), d1(H, W);
    FlowField fl = FlowField::zeros(W, H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            d0(y, x) = (x * 3 + y + seed) % 11 == 0 ? kInvalidDisparity : 20.0f + 0.5f * x;
            d1(y, x) = (x + 2 * y + seed) % 7 == 0 ? kInvalidDisparity : 19.0f + 0.5f * x;
            fl.u(y, x) = 2.0f + 0.25f * y;
            fl.v(y, x) = -1.0f;
            fl.valid(y, x) = (x + 5 * y + seed) % 13 != 0;
        }
    io::write_disparity_png(k.gt_disp0(id, true), d0);
    io::write_disparity_png(k.gt_disp1(id, true), d1);
    io::write_flow_png(k.gt_flow(id, true), fl);
    for (int x = 0; x < W; ++x) d0(3, x) = d1(3, x) = kInvalidDisparity;
    fl.valid.row(4).setTo(0);
    io::write_disparity_png(k.gt_disp0(id, false), d0);
    io::write_disparity_png(k.gt_disp1(id, false), d1);
    io::write_flow_png(k.gt_flow(id, false), fl);
}

// Copies the occ ground truth into a submission folder through the codec (decode + encode).
void submit_gt(const std::string &root, const std::string &est, const std::string &id) {
    const io::KittiLayout k{root}, e{est};
    io::write_disparity_png(e.est_disp0(id), io::read_disparity_png(k.gt_disp0(id, true)));
    io::write_disparity_png(e.est_disp1(id), io::read_disparity_png(k.gt_disp1(id, true)));
    io::write_flow_png(e.est_flow(id), io::read_flow_png(k.gt_flow(id, true)));
}

struct Fixture {
    std::string root, est;
};

Fixture make_fixture(const std::string &name) {
    const fs::path dir = test::scratch_dir(name);
    Fixture f{(dir / "gt").string(), (dir / "est").string()};
    for (int i = 0; i < 2; ++i) {
        const std::string id = i == 0 ? "000000" : "000001";
        write_synthetic_gt(f.root, id, i);
        submit_gt(f.root, f.est, id);
    }
    return f;
}

void gt_as_estimate_scores_zero(void **) {
    const Fixture f = make_fixture("eval_cli_zero");
    const std::string json = fs::path(f.est).parent_path().string() + "/out/result.json";
    const Run r = run_cli("--root '" + f.root + "' --est '" + f.est + "' --json '" + json + "'");
    if (r.code != 0) fail_msg("rc %d:\n%s", r.code, r.output.c_str());
    expect_contains(r.output, "000000");
    expect_contains(r.output, "000001");
    expect_contains(r.output, "pooled          occ     0.00    0.00    0.00    0.00");
    expect_contains(r.output, "mean/frame      occ     0.00    0.00    0.00    0.00");
    expect_contains(r.output, "                noc     0.00    0.00    0.00    0.00");
    expect_contains(r.output, "100.00  100.00  100.00  100.00");
    const std::string j = slurp(json);
    expect_wellformed_json(j);
    expect_contains(j, "\"format\": \"lidarflow-eval/1\"");
    expect_contains(j, "\"mode\": \"filled\"");
    expect_contains(j, "\"pooled\": {");
    expect_contains(j, "\"mean_over_frames\": {");
    expect_contains(j, "\"noc\": {");
    expect_contains(j, "\"outlier_pct\": 0.0,");
    expect_contains(j, "\"density_pct\": 100.0,");
    assert_false(contains(j, "\"lidar\""));
    for (const char *bad : {"\"n_err\": 1", "\"n_err\": 2", "\"n_err\": 3", "\"n_err\": 4", "\"n_err\": 5",
                            "\"n_err\": 6", "\"n_err\": 7", "\"n_err\": 8", "\"n_err\": 9"})
        assert_false(contains(j, bad));
}

void planted_outliers_are_counted(void **) {
    const Fixture f = make_fixture("eval_cli_planted");
    const io::KittiLayout e{f.est};
    // Five D0 outliers (+10 px on 20..31 px) where the occ and noc GT are valid (row 0, x 1..5
    // avoid the (3x + y + 1) % 11 holes of frame 000001).
    DisparityMap d0 = io::read_disparity_png(e.est_disp0("000001"));
    int planted = 0;
    for (int x = 0; x < W && planted < 5; ++x)
        if (d0(0, x) >= 0) {
            d0(0, x) += 10.0f;
            ++planted;
        }
    io::write_disparity_png(e.est_disp0("000001"), d0);
    const std::string json = f.est + "/../planted.json";
    const Run r = run_cli("--root '" + f.root + "' --est '" + f.est + "' --ids 000001 --json '" + json + "'");
    if (r.code != 0) fail_msg("rc %d:\n%s", r.code, r.output.c_str());
    assert_false(contains(r.output, "000000"));
    const std::string j = slurp(json);
    expect_wellformed_json(j);
    expect_contains(j, "\"n_err\": 5,");  // D0 and SF, occ and noc

    // est-only mode and Table II with a seed map: one seed at an outlier, one elsewhere.
    DisparityMap seeds(H, W, kInvalidDisparity);
    seeds(0, 1) = 25.0f;
    seeds(10, 10) = 25.0f;
    const std::string lidar = f.est + "/../lidar";
    io::write_disparity_png(io::KittiLayout{lidar}.lidar("000001", 0), seeds);
    const Run t = run_cli("--root '" + f.root + "' --est '" + f.est + "' --ids 000001 --mode est-only --window 3 --lidar '" +
                          lidar + "' --json '" + json + "'");
    if (t.code != 0) fail_msg("rc %d:\n%s", t.code, t.output.c_str());
    expect_contains(t.output, "mode est-only");
    expect_contains(t.output, "Table II");
    expect_contains(t.output, "3x3");
    const std::string j2 = slurp(json);
    expect_wellformed_json(j2);
    expect_contains(j2, "\"mode\": \"est-only\"");
    expect_contains(j2, "\"window\": 3");
    expect_contains(j2, "\"n_seeds\": 2");
    expect_contains(j2, "\"window_excl_seeds\": {");
}

void missing_file_fails_clearly(void **) {
    const Fixture f = make_fixture("eval_cli_missing");
    fs::remove(io::KittiLayout{f.est}.est_flow("000001"));
    const Run r = run_cli("--root '" + f.root + "' --est '" + f.est + "'");
    assert_true(r.code != 0);
    expect_contains(r.output, "missing estimate file");
    expect_contains(r.output, "flow/000001_10.png");

    const Run ids = run_cli("--root '" + f.root + "' --est '" + f.est + "' --ids 000007");
    assert_true(ids.code != 0);
    expect_contains(ids.output, "000007_10.png");

    const Run lidar = run_cli("--root '" + f.root + "' --est '" + f.est + "' --ids 000000 --lidar /nonexistent/lidar");
    assert_true(lidar.code != 0);
    expect_contains(lidar.output, "lidar_0/000000_10.png");
}

void bad_options_and_sizes_fail(void **) {
    const Fixture f = make_fixture("eval_cli_bad");
    const std::string base = "--root '" + f.root + "' --est '" + f.est + "'";
    Run r = run_cli(base + " --mode dense");
    assert_int_equal(r.code, 2);
    expect_contains(r.output, "--mode");
    r = run_cli(base + " --window 4");
    assert_int_equal(r.code, 2);
    expect_contains(r.output, "--window");
    r = run_cli("--est '" + f.est + "'");
    assert_int_equal(r.code, 2);
    expect_contains(r.output, "--root");
    r = run_cli("--root '" + f.root + "' --est '" + f.root + "'");  // no disp_0/ there
    assert_true(r.code != 0);
    expect_contains(r.output, "disp_0");

    io::write_disparity_png(io::KittiLayout{f.est}.est_disp1("000000"), DisparityMap(H, W + 1, 1.0f));
    r = run_cli(base);
    assert_int_equal(r.code, 1);
    expect_contains(r.output, "frame 000000");
    expect_contains(r.output, "estimate d1");

    r = run_cli("--help");
    assert_int_equal(r.code, 0);
    expect_contains(r.output, "--lidar");
}

void real_frames_gt_as_estimate(void **) {
    const std::string root = test::kitti_dir();
    if (root.empty()) {
        std::printf("real_frames_gt_as_estimate: skipped: LIDARFLOW_KITTI_DIR not set\n");
        skip();
    }
    const fs::path dir = test::scratch_dir("eval_cli_real");
    const std::string est = (dir / "est").string(), json = (dir / "real.json").string();
    const auto ids = io::KittiLayout{root}.frame_ids();
    for (const std::string &id : ids) submit_gt(root, est, id);
    const Run r = run_cli("--root '" + root + "' --est '" + est + "' --json '" + json + "'");
    if (r.code != 0) fail_msg("rc %d:\n%s", r.code, r.output.c_str());
    std::printf("%s", r.output.c_str());
    for (const std::string &id : ids) expect_contains(r.output, id + "          occ     0.00    0.00    0.00    0.00");
    expect_contains(r.output, "pooled          occ     0.00    0.00    0.00    0.00");
    const std::string j = slurp(json);
    expect_wellformed_json(j);
    expect_contains(j, "\"id\": \"" + ids.front() + "\"");
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(gt_as_estimate_scores_zero),
        cmocka_unit_test(planted_outliers_are_counted),
        cmocka_unit_test(missing_file_fails_clearly),
        cmocka_unit_test(bad_options_and_sizes_fail),
        cmocka_unit_test(real_frames_gt_as_estimate),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
