// SPDX-License-Identifier: MIT
#include "option_assignments.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "core/closest_name.hpp"
#include "core/error.hpp"
#include "option_keys.hpp"

namespace lidarflow::cli {

void apply_option_assignments(pipeline::EstimatorOptions &options, const std::vector<std::string> &assignments) {
    capi::OptionValues values;
    values.estimator = options;
    for (const std::string &a : assignments) {
        const size_t eq = a.find('=');
        require(eq != std::string::npos && eq > 0, ErrorCode::InvalidArgument,
                "--set: expected KEY=VALUE, got '" + a + "'");
        const std::string key = a.substr(0, eq), value = a.substr(eq + 1);
        const capi::OptionKey *k = capi::find_option_key(key);
        require(k != nullptr, ErrorCode::InvalidArgument, [&] {
            return "--set: unknown option key '" + key + "'" + did_you_mean(key, capi::option_key_names()) +
                   " (lidarflow options lists them)";
        });
        const char *begin = value.c_str();
        char *end = nullptr;
        errno = 0;
        switch (capi::option_key_type(*k)) {
        case capi::KeyType::String: capi::set_option_string(values, *k, value); break;
        case capi::KeyType::Int:
        case capi::KeyType::Bool: {
            const long long v = std::strtoll(begin, &end, 10);
            require(!value.empty() && *end == '\0' && errno == 0, ErrorCode::InvalidArgument,
                    "--set: '" + key + "' needs an integer, got '" + value + "'");
            capi::set_option_int(values, *k, v);
            break;
        }
        case capi::KeyType::Float: {
            const double v = std::strtod(begin, &end);
            require(!value.empty() && *end == '\0' && errno == 0 && std::isfinite(v), ErrorCode::InvalidArgument,
                    "--set: '" + key + "' needs a finite number, got '" + value + "'");
            capi::set_option_float(values, *k, v);
            break;
        }
        }
    }
    options = values.estimator;
}

}  // namespace lidarflow::cli
