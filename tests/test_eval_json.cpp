// SPDX-License-Identifier: MIT
// The --json report read back with nlohmann-json: a fixed evaluation (two frames, noc, a LiDAR
// seed map, an empty component) must give the same document as the hand-written writer that the
// library replaced (tests/eval_report_v1.json, its output for this evaluation), keys in the
// documented order, doubles that round-trip exactly and null where nothing was scored.
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "eval/json_report.hpp"
// cmocka.h defines fail(), which breaks <ios>: include it after every C++ header. Its 1.1.5
// header has no extern "C" of its own, so wrap it here.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}

using namespace lidarflow;
using namespace lidarflow::eval;

namespace {

Counts counts(int64_t gt, int64_t est, int64_t total, int64_t err, double abs_err) {
    Counts c;
    c.n_gt = gt, c.n_est = est, c.n_total = total, c.n_err = err, c.abs_err_sum = abs_err;
    return c;
}

ComponentScores components(int k) {
    ComponentScores s;
    s.d0 = counts(300 + k, 290 + k, 300 + k, 7 + k, 123.456 + k);
    s.d1 = counts(299, 280, 299, 3, 0.1 * (k + 1));
    s.fl = counts(3, 3, 3, 1, 1.0 / 3.0);  // 33.333...% and an EPE that need all 17 digits
    s.sf = counts(0, 0, 0, 0, 0);         // nothing to score: null percentages
    return s;
}

RegionScores region(int k) {
    RegionScores r;
    r.occ = components(k);
    r.has_noc = true;
    r.noc = components(k + 10);
    return r;
}

KittiEvaluation fixed_evaluation() {
    KittiEvaluation ev;
    ev.options.mode = FillMode::EstimateOnly;
    ev.options.window = 5;
    for (int i = 0; i < 2; ++i) {
        FrameScore f;
        f.id = i == 0 ? "000000" : "odd \"id\"\\\x01";  // escapes survive the round trip
        f.dense = region(i);
        f.has_lidar = true;
        f.n_seeds = 17 + i;
        f.seeds = region(20 + i);
        f.window = region(40 + i);
        f.window_excl_seeds = region(60 + i);
        ev.frames.push_back(f);
    }
    ev.summary = summarize(ev.frames);
    return ev;
}

void same_document_as_the_hand_written_writer(void **) {
    const std::string text = to_json(fixed_evaluation());
    std::ifstream f(LIDARFLOW_TEST_SOURCE_DIR "/eval_report_v1.json");
    assert_true(f.good());
    const nlohmann::ordered_json before = nlohmann::ordered_json::parse(f);
    const nlohmann::ordered_json now = nlohmann::ordered_json::parse(text);
    // ordered_json compares keys in order too; doubles compare exactly (both round-trip).
    if (now != before) fail_msg("report differs from tests/eval_report_v1.json:\n%s", text.c_str());
}

void values_round_trip(void **) {
    const KittiEvaluation ev = fixed_evaluation();
    const nlohmann::ordered_json j = nlohmann::ordered_json::parse(to_json(ev));
    std::string top;
    for (const auto &kv : j.items()) top += kv.key() + " ";
    assert_string_equal(top.c_str(), "format mode window frames pooled mean_over_frames ");
    assert_true(j["format"] == "lidarflow-eval/1");
    assert_true(j["mode"] == "est-only");
    assert_int_equal(j["window"].get<int>(), 5);
    assert_int_equal(j["frames"].size(), 2);
    assert_true(j["frames"][1]["id"] == ev.frames[1].id);

    const Counts &fl = ev.frames[0].window.noc.fl;
    const auto &jfl = j["frames"][0]["lidar"]["window"]["noc"]["fl"];
    assert_true(jfl["outlier_pct"].get<double>() == fl.outlier_pct());  // bit for bit
    assert_true(jfl["epe"].get<double>() == fl.epe());
    assert_int_equal(jfl["n_err"].get<int64_t>(), fl.n_err);
    assert_true(jfl["n_err"].is_number_integer());
    assert_int_equal(j["frames"][1]["lidar"]["n_seeds"].get<int64_t>(), 18);

    const auto &sf = j["pooled"]["dense"]["occ"]["sf"];
    assert_true(sf["outlier_pct"].is_null());  // NaN: nothing scored
    assert_true(sf["density_pct"].is_null());
    assert_false(sf.contains("epe"));
    assert_int_equal(sf["n_total"].get<int64_t>(), 0);

    const MeanStat &m = ev.summary.mean_window_excl_seeds.noc.d1;
    const auto &jm = j["mean_over_frames"]["window_excl_seeds"]["noc"]["d1"];
    assert_true(jm["epe"].get<double>() == m.epe);
    assert_int_equal(jm["frames_scored"].get<int>(), 2);
    assert_true(j["mean_over_frames"]["dense"]["occ"]["sf"]["outlier_pct"].is_null());
}

void est_only_without_lidar_or_noc(void **) {
    KittiEvaluation ev;
    FrameScore f;
    f.id = "000007";
    f.dense.occ = components(0);
    ev.frames.push_back(f);
    ev.summary = summarize(ev.frames);
    const nlohmann::json j = nlohmann::json::parse(to_json(ev));
    assert_true(j["mode"] == "filled");
    assert_false(j["frames"][0].contains("lidar"));
    assert_false(j["frames"][0]["dense"].contains("noc"));
    assert_false(j["mean_over_frames"].contains("seeds"));
    assert_int_equal(j["mean_over_frames"].size(), 1);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(same_document_as_the_hand_written_writer),
        cmocka_unit_test(values_round_trip),
        cmocka_unit_test(est_only_without_lidar_or_noc),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
