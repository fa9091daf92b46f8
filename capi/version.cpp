// SPDX-License-Identifier: MIT
// The status and version part of the C ABI. Nothing here can throw.
#include "lidarflow/lidarflow.h"

extern "C" {

LF_API const char *lf_status_string(int32_t status) {
    switch (status) {
    case LF_OK: return "ok";
    case LF_ERR_INVALID_ARGUMENT: return "invalid argument";
    case LF_ERR_SIZE_MISMATCH: return "size mismatch";
    case LF_ERR_IO: return "i/o error";
    case LF_ERR_FORMAT: return "corrupt or unsupported format";
    case LF_ERR_BAD_STATE: return "call not allowed in the current state";
    case LF_ERR_NOT_READY: return "no result available yet";
    case LF_ERR_OUT_OF_MEMORY: return "out of memory";
    case LF_ERR_INTERNAL: return "internal error";
    default: return "unknown status";
    }
}

LF_API uint32_t lf_version_number(void) { return LF_VERSION_NUMBER; }

LF_API const char *lf_version_string(void) { return LF_VERSION_STRING; }

LF_API uint32_t lf_abi_major(void) { return LF_ABI_MAJOR; }

}  // extern "C"
