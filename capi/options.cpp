// SPDX-License-Identifier: MIT
// lf_options_*: the key/value settings object of the C ABI (keys in src/pipeline/option_keys.cpp).
#include <new>

#include "core/closest_name.hpp"
#include "guard.hpp"
#include "handles.hpp"

using lidarflow::ErrorCode;
using lidarflow::require;
using namespace lidarflow::capi;
using namespace lidarflow::pipeline;

namespace {

const OptionKey &lookup(const char *key) {
    require_non_null(key, "key");
    const OptionKey *k = find_option_key(key);
    require(k != nullptr, ErrorCode::InvalidArgument, [&] {
        return std::string("unknown option key '") + key + "'" + lidarflow::did_you_mean(key, option_key_names());
    });
    return *k;
}

ErrorSink sink_of(lf_options_t *options) { return ErrorSink(options ? &options->error : nullptr); }

}  // namespace

extern "C" {

LF_API int32_t lf_options_create(lf_options_t **out) {
    return guarded(ErrorSink(nullptr), "lf_options_create", [&] {
        require_non_null(out, "out");
        *out = nullptr;
        *out = new lf_options();
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API void lf_options_destroy(lf_options_t *options) { delete options; }

LF_API int32_t lf_options_set_int(lf_options_t *options, const char *key, int64_t value) {
    return guarded(sink_of(options), "lf_options_set_int", [&] {
        require_non_null(options, "options");
        set_option_int(options->values, lookup(key), value);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_options_set_float(lf_options_t *options, const char *key, double value) {
    return guarded(sink_of(options), "lf_options_set_float", [&] {
        require_non_null(options, "options");
        set_option_float(options->values, lookup(key), value);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_options_set_string(lf_options_t *options, const char *key, const char *value) {
    return guarded(sink_of(options), "lf_options_set_string", [&] {
        require_non_null(options, "options");
        const OptionKey &k = lookup(key);
        require_non_null(value, "value");
        // Build the new values aside: a failed set leaves the object unchanged.
        OptionValues next = options->values;
        set_option_string(next, k, value);
        options->values = std::move(next);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_options_get_int(lf_options_t *options, const char *key, int64_t *out) {
    return guarded(sink_of(options), "lf_options_get_int", [&] {
        require_non_null(options, "options");
        const OptionKey &k = lookup(key);
        require_non_null(out, "out");
        *out = get_option_int(options->values, k);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_options_get_float(lf_options_t *options, const char *key, double *out) {
    return guarded(sink_of(options), "lf_options_get_float", [&] {
        require_non_null(options, "options");
        const OptionKey &k = lookup(key);
        require_non_null(out, "out");
        *out = get_option_float(options->values, k);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_options_get_string(lf_options_t *options, const char *key, const char **out) {
    return guarded(sink_of(options), "lf_options_get_string", [&] {
        require_non_null(options, "options");
        const OptionKey &k = lookup(key);
        require_non_null(out, "out");
        *out = get_option_string(options->values, k);
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API const char *lf_options_last_error(const lf_options_t *options) {
    return options ? options->error.c_str() : thread_last_error().c_str();
}

}  // extern "C"
