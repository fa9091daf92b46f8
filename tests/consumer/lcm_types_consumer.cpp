// SPDX-License-Identifier: MIT
// Built from an installed tree only: the generated C++ type (header-only) and the generated C
// type (header + source compiled in) of the same message must encode to the same bytes and
// decode back, so the installed definitions, headers and sources belong together.
#include <lidarflow/status_t.hpp>

extern "C" {
#include <lidarflow_status_t.h>
}

#include <cstdio>
#include <cstring>
#include <vector>

int main() {
    lidarflow::status_t cpp{};
    cpp.utime = 1234567;
    cpp.stereo_received = 42;
    cpp.dropped_stale = 3;
    const int n = cpp.getEncodedSize();
    std::vector<unsigned char> a(n), b(n);
    if (cpp.encode(a.data(), 0, n) != n) { std::puts("C++ encode failed"); return 1; }

    lidarflow_status_t c;
    if (lidarflow_status_t_decode(a.data(), 0, n, &c) != n) { std::puts("C decode failed"); return 1; }
    if (c.utime != 1234567 || c.stereo_received != 42 || c.dropped_stale != 3) {
        std::puts("C decode differs from what C++ encoded");
        return 1;
    }
    if (lidarflow_status_t_encode(b.data(), 0, n, &c) != n || std::memcmp(a.data(), b.data(), n) != 0) {
        std::puts("C re-encode differs from C++ encode");
        return 1;
    }
    lidarflow_status_t_decode_cleanup(&c);
    std::printf("lcm types: C and C++ agree on %d bytes\n", n);
    return 0;
}
