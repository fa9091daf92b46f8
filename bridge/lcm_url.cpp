// SPDX-License-Identifier: MIT
#include "lcm_url.hpp"

#include <climits>
#include <cstdlib>
#include <fstream>

namespace lidarflow::bridge {

namespace {

// A positive decimal integer that fits LCM's int, or -1.
long long parse_size(const std::string &s) {
    if (s.empty() || s.size() > 10) return -1;
    long long v = 0;
    for (char c : s) {
        if (c < '0' || c > '9') return -1;
        v = v * 10 + (c - '0');
    }
    return v > 0 && v <= INT_MAX ? v : -1;
}

}  // namespace

ReceiveBufferFit fit_receive_buffer(const std::string &url, long long rmem_max) {
    ReceiveBufferFit fit;
    fit.url = url;
    if (url.compare(0, 7, "udpm://") != 0 || rmem_max <= 0) return fit;
    const size_t q = url.find('?');
    std::string base = url.substr(0, q), query = q == std::string::npos ? "" : url.substr(q + 1);
    std::string kept;  // the other options, in their order
    long long wanted = 0;
    size_t pos = 0;
    while (pos <= query.size() && !query.empty()) {
        const size_t amp = query.find('&', pos);
        const std::string item = query.substr(pos, amp == std::string::npos ? std::string::npos : amp - pos);
        if (item.compare(0, 14, "recv_buf_size=") == 0) {
            wanted = parse_size(item.substr(14));
            if (wanted < 0) return fit;
        } else if (!item.empty()) {
            kept += (kept.empty() ? "" : "&") + item;
        }
        if (amp == std::string::npos) break;
        pos = amp + 1;
    }
    if (wanted == 0) wanted = kWantedReceiveBuffer;
    const long long requested = wanted < rmem_max ? wanted : (rmem_max < INT_MAX ? rmem_max : INT_MAX);
    fit.wanted = wanted;
    fit.requested = requested;
    fit.url = base + "?" + kept + (kept.empty() ? "" : "&") + "recv_buf_size=" + std::to_string(requested);
    return fit;
}

long long read_rmem_max() {
    std::ifstream f("/proc/sys/net/core/rmem_max");
    long long v = -1;
    if (!(f >> v) || v <= 0) return -1;
    return v;
}

std::string effective_lcm_url(const std::string &url) {
    if (!url.empty()) return url;
    const char *env = std::getenv("LCM_DEFAULT_URL");
    return env && *env ? env : kLcmDefaultUrl;
}

}  // namespace lidarflow::bridge
