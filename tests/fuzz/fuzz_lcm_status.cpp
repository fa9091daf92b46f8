// SPDX-License-Identifier: MIT
// status_t through the bridge's decoder (bridge/wire.cpp decode_status, what the log checker
// and monitoring tools use). What decodes carries a string that ends inside the message.
#include <cstdint>
#include <cstdlib>

#include "wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lidarflow::bridge::StatusMessage s;
    if (!lidarflow::bridge::decode_status(data, size, s).empty()) return 0;
    if (s.fields.last_error != nullptr || s.last_error.size() + 8 + 177 + 1 > size) std::abort();
    return 0;
}
