// SPDX-License-Identifier: MIT
// status_t through the bridge's decoder (bridge/wire.cpp decode_status, what the log checker
// and monitoring tools use). What decodes carries a string that ends inside the message.
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow::bridge::StatusMessage s;
    if (!lidarflow::bridge::decode_status(data, size, s).empty()) return 0;
    // The message holds the fingerprint, the fixed fields, the string's length, its bytes and a
    // NUL: at least the encoded size of the same status with last_error "" plus the string's
    // bytes (more when the wire string has a NUL inside: the text ends there).
    lidarflow_status_t empty = s.fields;
    empty.last_error = const_cast<char *>("");
    if (s.fields.last_error != nullptr ||
        s.last_error.size() + static_cast<size_t>(lidarflow_status_t_encoded_size(&empty)) > size)
        std::abort();
    return 0;
}
