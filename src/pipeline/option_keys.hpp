// SPDX-License-Identifier: MIT
#pragma once
// The option key table of the estimator: every key, its type, bounds and the EstimatorOptions
// field it writes. One table for every front end: the C ABI's lf_options_t (capi/options.cpp),
// `--set KEY=VALUE` of the CLI and bench_pipeline (option_assignments.hpp) and `lidarflow
// options`. The C header's key table documents the same bounds; tests/test_capi_options.c
// checks both ends of each.
#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/estimator.hpp"

namespace lidarflow::pipeline {

// What the options object holds: the estimator settings plus the names of the string keys.
struct OptionValues {
    EstimatorOptions estimator = EstimatorOptions::preset("default");
    std::string preset = "default";
};

enum class OptionKeyType { Int, Bool, Float, String };

struct OptionKey;

// Looks a key up; nullptr when unknown.
const OptionKey *find_option_key(const std::string &key);
// Every key's name, in table order.
std::vector<std::string> option_key_names();

// One row of `lidarflow options`: the table itself, not a copy of the header's documentation.
struct OptionKeyDescription {
    std::string name;
    std::string type;         // "int", "0/1", "float", "string"
    std::string bounds;       // e.g. "[1, 256]", "(0, 10000]", "[1, 101] and odd"; the names a string key takes
    std::string value;        // the key's value in the described options, as `--set` takes it
    std::string description;  // one line
};
// Every key in table order, with its value in `values` (default: a fresh lf_options_t).
std::vector<OptionKeyDescription> describe_option_keys(const OptionValues &values = OptionValues{});
OptionKeyType option_key_type(const OptionKey &k);

// Setters: check type and bounds, then write. Throw Error(InvalidArgument) naming the key,
// the bounds and the rejected value; `values` is untouched then.
void set_option_int(OptionValues &values, const OptionKey &k, int64_t v);
void set_option_float(OptionValues &values, const OptionKey &k, double v);
void set_option_string(OptionValues &values, const OptionKey &k, const std::string &v);

// Getters (Int/Bool keys as integers; any numeric key as double; String keys as a string
// that points into `values`). Throw Error(InvalidArgument) on a type mismatch.
int64_t get_option_int(const OptionValues &values, const OptionKey &k);
double get_option_float(const OptionValues &values, const OptionKey &k);
const char *get_option_string(const OptionValues &values, const OptionKey &k);

// Every option that can change a result, one "key=value" per line in table order (floats to 17
// digits): what a result written by these options records of them. Leaves out the keys that
// only schedule the work (threads, adaptive_threads), frames_in_flight at 1 (the stream) and the
// preset's name (its values are in).
std::string result_settings_text(const EstimatorOptions &options);

// The option values of a named preset (threads kept from `current`). Throws
// Error(InvalidArgument) for an unknown name.
OptionValues preset_values(const std::string &name, const OptionValues &current);

}  // namespace lidarflow::pipeline
