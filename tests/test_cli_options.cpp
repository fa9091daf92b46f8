// SPDX-License-Identifier: MIT
// lidarflow options and the "did you mean" of unknown keys and flags: the listing comes from the
// C ABI's key table (every key, its bounds, the default a fresh lf_options_t holds and a line of
// description), --preset NAME shows each key's value under that preset, --set takes the named
// presets, typos get the nearest name, and kitti says why it takes no rig options.
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>

#include "core/closest_name.hpp"
#include "pipeline/option_keys.hpp"

// cmocka.h after every C++ header, wrapped (its 1.1.5 header has no extern "C").
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;

namespace {

using Run = test::CliRun;
using test::run_cli;

bool contains(const std::string &s, const std::string &what) { return s.find(what) != std::string::npos; }

void test_closest_name(void **) {
    const std::vector<std::string> names = {"threads", "preset", "matching.grid_step", "matching.iterations",
                                            "interpolation.iterations"};
    assert_string_equal(closest_name("thread", names).c_str(), "threads");
    assert_string_equal(closest_name("prset", names).c_str(), "preset");
    assert_string_equal(closest_name("grid_step", names).c_str(), "matching.grid_step");
    assert_string_equal(closest_name("matching.iteration", names).c_str(), "matching.iterations");
    assert_string_equal(closest_name("banana", names).c_str(), "");
    assert_string_equal(closest_name("", names).c_str(), "");
    assert_string_equal(did_you_mean("thread", names).c_str(), " (did you mean 'threads'?)");
    assert_string_equal(did_you_mean("zzz", names).c_str(), "");
}

void test_options_lists_every_key_with_its_default(void **) {
    const Run r = run_cli("options");
    assert_int_equal(r.code, 0);
    const std::vector<pipeline::OptionKeyDescription> keys = pipeline::describe_option_keys();
    assert_true(keys.size() > 50);
    std::istringstream lines(r.output);
    std::string line;
    size_t rows = 0;
    while (std::getline(lines, line)) {
        if (line.empty() || line[0] == ' ') continue;  // a description line
        std::istringstream cols(line);
        std::string name;
        cols >> name;
        const pipeline::OptionKey *k = pipeline::find_option_key(name);
        if (!k) continue;
        ++rows;
        // The last column is the default; the row names the type and bounds too, the next line
        // says what the key does.
        for (const pipeline::OptionKeyDescription &d : keys) {
            if (d.name != name) continue;
            assert_true(line.size() >= d.value.size() &&
                        line.compare(line.size() - d.value.size(), std::string::npos, d.value) == 0);
            assert_true(contains(line, d.type) && contains(line, d.bounds));
            std::string description;
            assert_true(static_cast<bool>(std::getline(lines, description)));
            assert_true(d.description.size() > 10);
            assert_true(description == "    " + d.description);
        }
    }
    assert_int_equal(rows, keys.size());
    assert_true(contains(r.output, "threads") && contains(r.output, "[1, 256]"));
    assert_true(contains(r.output, "default | paper | balanced | fast"));
    assert_true(contains(r.output, "(0, 10000]"));  // an open bound
}

// The value text of a key in `values`, from the core's preset and the typed getters (not from
// the listing's own formatting): ints exact, floats as float32, strings quoted.
bool value_matches(const std::string &shown, const pipeline::OptionValues &values, const pipeline::OptionKey &k) {
    switch (pipeline::option_key_type(k)) {
    case pipeline::OptionKeyType::String:
        return shown == std::string("\"") + pipeline::get_option_string(values, k) + "\"";
    case pipeline::OptionKeyType::Float:
        return static_cast<float>(std::strtod(shown.c_str(), nullptr)) ==
               static_cast<float>(pipeline::get_option_float(values, k));
    default:
        return shown == std::to_string(pipeline::get_option_int(values, k));
    }
}

// `options --preset NAME`: every key, its value as EstimatorOptions::preset(NAME) has it, a star
// exactly where it differs from "paper" (the field defaults), and its description line.
void test_options_preset_shows_each_keys_value(void **) {
    pipeline::OptionValues paper;
    paper.estimator = pipeline::EstimatorOptions::preset("paper");
    paper.preset = "paper";
    for (const char *name : {"default", "paper", "balanced", "fast", "realtime"}) {
        const Run r = run_cli(std::string("options --preset ") + name);
        if (r.code != 0) fail_msg("options --preset %s: exit %d: %s", name, r.code, r.output.c_str());
        pipeline::OptionValues expected;
        expected.estimator = pipeline::EstimatorOptions::preset(name);
        expected.preset = name;
        const std::vector<pipeline::OptionKeyDescription> keys = pipeline::describe_option_keys();
        std::map<std::string, std::string> rows;  // key -> the rest of its row after the bounds
        std::istringstream lines(r.output);
        std::string line;
        while (std::getline(lines, line) && line.compare(0, 4, "key ") != 0) continue;  // the title above
        while (std::getline(lines, line)) {
            std::istringstream cols(line);
            std::string key;
            cols >> key;
            if (line.empty() || line[0] == ' ' || !pipeline::find_option_key(key)) continue;
            for (const pipeline::OptionKeyDescription &d : keys)
                if (d.name == key) rows[key] = line.substr(line.find(d.bounds, key.size()) + d.bounds.size());
            std::string description;
            assert_true(static_cast<bool>(std::getline(lines, description)) && description.size() > 14 &&
                        description.compare(0, 4, "    ") == 0);
        }
        assert_int_equal(rows.size(), keys.size());
        int stars = 0;
        for (const auto &kv : rows) {
            if (kv.first == "threads") continue;  // the machine's, kept from the options it started from
            const pipeline::OptionKey &k = *pipeline::find_option_key(kv.first);
            std::istringstream rest(kv.second);
            std::string value;
            rest >> value;
            if (!value_matches(value, expected, k))
                fail_msg("preset %s: %s shows %s", name, kv.first.c_str(), value.c_str());
            const bool star = contains(kv.second, "*");
            const bool differs = kv.first != "preset" && !value_matches(value, paper, k);
            if (star != differs) fail_msg("preset %s: %s marked %d, differs from paper %d", name, kv.first.c_str(), star, differs);
            stars += star;
        }
        // paper marks nothing; the decoupled presets differ in many keys
        if (std::string(name) == "paper") assert_int_equal(stars, 0);
        if (std::string(name) == "realtime") assert_true(stars > 10);
    }
    const Run bad = run_cli("options --preset turbo");
    assert_int_equal(bad.code, 2);
    assert_true(contains(bad.output, "unknown preset 'turbo'"));
    assert_true(contains(bad.output, "realtime"));  // the names it takes
}

void test_unknown_keys_and_flags_get_a_suggestion(void **) {
    Run r = run_cli("demo --set thread=2 --out /nonexistent/dir");
    assert_int_equal(r.code, 2);
    assert_true(contains(r.output, "unknown option key 'thread' (did you mean 'threads'?)"));
    r = run_cli("run --left0 x --rigth0 x");
    assert_int_equal(r.code, 2);
    assert_true(contains(r.output, "unknown option --rigth0 (did you mean --right0?)"));
    r = run_cli("kitti --presett fast");
    assert_int_equal(r.code, 2);
    assert_true(contains(r.output, "did you mean --preset?"));
    r = run_cli("run --bananas 3");
    assert_int_equal(r.code, 2);
    assert_true(contains(r.output, "unknown option --bananas (see --help)"));
}

// kitti takes each frame's calibration: a rig option is refused with the reason, not as unknown.
void test_kitti_refuses_a_rig(void **) {
    for (const char *rig : {"--calib stereo.yml", "--calib=left.yaml,right.yaml", "--fx 700"}) {
        const Run r = run_cli(std::string("kitti --root /nonexistent/dir ") + rig);
        assert_int_equal(r.code, 2);
        assert_true(contains(r.output, "kitti takes no --"));
        assert_true(contains(r.output, "each KITTI frame has its own calibration"));
        assert_true(contains(r.output, "sequence --calib"));
    }
}

void test_set_takes_named_presets(void **) {
    // demo renders a small synthetic pair: --set preset=fast must be accepted and reach the run
    // (an unknown preset fails before any work).
    Run r = run_cli("demo --set preset=turbo --out /nonexistent/dir");
    assert_int_equal(r.code, 2);
    assert_true(contains(r.output, "unknown preset 'turbo'"));
    pipeline::OptionValues v;
    pipeline::set_option_string(v, *pipeline::find_option_key("preset"), "fast");
    assert_int_equal(v.estimator.matching.flow.patch_size, 6);
    assert_true(v.preset == "fast");
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closest_name),
        cmocka_unit_test(test_options_lists_every_key_with_its_default),
        cmocka_unit_test(test_options_preset_shows_each_keys_value),
        cmocka_unit_test(test_unknown_keys_and_flags_get_a_suggestion),
        cmocka_unit_test(test_set_takes_named_presets),
        cmocka_unit_test(test_kitti_refuses_a_rig),
    };
    return cmocka_run_group_tests_name("cli_options", tests, nullptr, nullptr);
}
