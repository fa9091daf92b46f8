/*
 * lidarflow — dense scene flow from a rectified stereo camera and a sparse LiDAR.
 *
 * This is the library's one stable C ABI. Everything the shared library exports is declared
 * here; the C++ core behind it is private and no C++ exception ever crosses this boundary.
 *
 * Conventions
 *  - Every function is prefixed lf_, every type lf_*_t, every macro LF_.
 *  - Only fixed-width integer types, float/double and pointers appear in signatures.
 *  - Status codes are explicitly numbered and are never renumbered; new codes are appended.
 *  - Strings returned by the library are static, NUL-terminated, and owned by the library.
 *
 * This header grows as stages of the estimator land: a stage that is not built yet is not
 * declared here. Today it holds the status codes and the version queries.
 */
#ifndef LIDARFLOW_H
#define LIDARFLOW_H

#include <stdint.h>

#include "lidarflow/lidarflow_version.h"

#if defined(_WIN32)
#  define LF_API
#elif defined(LIDARFLOW_BUILDING_LIBRARY)
#  define LF_API __attribute__((visibility("default")))
#else
#  define LF_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Result of every fallible call. Values are part of the ABI and never change. */
typedef enum lf_status_t {
    LF_OK = 0,
    LF_ERR_INVALID_ARGUMENT = 1, /* NULL pointer, out-of-range option, NaN/inf input, ... */
    LF_ERR_SIZE_MISMATCH = 2,    /* image/buffer sizes or strides disagree */
    LF_ERR_IO = 3,               /* a file could not be opened, read or written */
    LF_ERR_FORMAT = 4,           /* a file or message is corrupt or of the wrong format */
    LF_ERR_BAD_STATE = 5,        /* call not allowed in the handle's current state */
    LF_ERR_NOT_READY = 6,        /* no result yet (e.g. only one frame pushed) */
    LF_ERR_OUT_OF_MEMORY = 7,
    LF_ERR_INTERNAL = 8          /* a bug in lidarflow: please report it */
} lf_status_t;

/* Human-readable, static English description of a status code; never NULL.
 * Unknown codes give "unknown status". Thread-safe. */
LF_API const char *lf_status_string(int32_t status);

/* Run-time version of the loaded library: major * 10000 + minor * 100 + patch.
 * Compare with LF_VERSION_NUMBER to detect a header/library mismatch. Thread-safe. */
LF_API uint32_t lf_version_number(void);

/* Run-time version string of the loaded library, e.g. "0.1.0"; static, never NULL.
 * Thread-safe. */
LF_API const char *lf_version_string(void);

/* ABI major version of the loaded library (the SONAME suffix). Thread-safe. */
LF_API uint32_t lf_abi_major(void);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* LIDARFLOW_H */
