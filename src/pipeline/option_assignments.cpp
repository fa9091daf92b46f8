// SPDX-License-Identifier: MIT
#include "pipeline/option_assignments.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "core/closest_name.hpp"
#include "core/error.hpp"
#include "pipeline/option_keys.hpp"

namespace lidarflow::pipeline {

void apply_option_assignments(EstimatorOptions &options, const std::vector<std::string> &assignments) {
    OptionValues values;
    values.estimator = options;
    for (const std::string &a : assignments) {
        const size_t eq = a.find('=');
        require(eq != std::string::npos && eq > 0, ErrorCode::InvalidArgument,
                "--set: expected KEY=VALUE, got '" + a + "'");
        const std::string key = a.substr(0, eq), value = a.substr(eq + 1);
        const OptionKey *k = find_option_key(key);
        require(k != nullptr, ErrorCode::InvalidArgument, [&] {
            return "--set: unknown option key '" + key + "'" + did_you_mean(key, option_key_names()) +
                   " (lidarflow options lists them)";
        });
        const char *begin = value.c_str();
        char *end = nullptr;
        errno = 0;
        switch (option_key_type(*k)) {
        case OptionKeyType::String: set_option_string(values, *k, value); break;
        case OptionKeyType::Int:
        case OptionKeyType::Bool: {
            const long long v = std::strtoll(begin, &end, 10);
            require(!value.empty() && *end == '\0' && errno == 0, ErrorCode::InvalidArgument,
                    "--set: '" + key + "' needs an integer, got '" + value + "'");
            set_option_int(values, *k, v);
            break;
        }
        case OptionKeyType::Float: {
            const double v = std::strtod(begin, &end);
            require(!value.empty() && *end == '\0' && errno == 0 && std::isfinite(v), ErrorCode::InvalidArgument,
                    "--set: '" + key + "' needs a finite number, got '" + value + "'");
            set_option_float(values, *k, v);
            break;
        }
        }
    }
    options = values.estimator;
}

}  // namespace lidarflow::pipeline
