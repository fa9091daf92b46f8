// SPDX-License-Identifier: MIT
#pragma once
// The receive buffer a udpm:// URL asks for, fitted to what the kernel grants: LCM prints a
// GLib warning whenever the URL's recv_buf_size exceeds what the kernel reports back (twice
// net.core.rmem_max), and a larger request gains nothing, since the kernel caps it anyway.
#include <string>

namespace lidarflow::bridge {

// What the bridge asks for when the URL names no recv_buf_size: room for multi-MB stereo
// messages (KITTI-size pairs arrive as dozens of fragments).
constexpr long long kWantedReceiveBuffer = 16777216;

// LCM 1.3.1's URL for lcm_create(NULL) when LCM_DEFAULT_URL is unset or empty.
constexpr const char *kLcmDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

struct ReceiveBufferFit {
    std::string url;         // the URL to pass to lcm_create
    long long wanted = 0;    // the URL's recv_buf_size, or kWantedReceiveBuffer; 0: not udpm or left alone
    long long requested = 0; // what `url` asks for: min(wanted, rmem_max); 0: left alone
    bool limited() const { return requested > 0 && requested < wanted; }
};

// For a udpm:// URL: the URL with recv_buf_size = min(its own or kWantedReceiveBuffer,
// rmem_max). Any other provider, an unknown limit (rmem_max <= 0) or a recv_buf_size that is
// not a positive decimal integer (LCM reports that itself) leaves the URL as it is.
ReceiveBufferFit fit_receive_buffer(const std::string &url, long long rmem_max);

// net.core.rmem_max from /proc/sys/net/core/rmem_max; -1 when it cannot be read.
long long read_rmem_max();

// The URL lcm_create would use for `url`: itself, else $LCM_DEFAULT_URL, else LCM's default.
std::string effective_lcm_url(const std::string &url);

}  // namespace lidarflow::bridge
