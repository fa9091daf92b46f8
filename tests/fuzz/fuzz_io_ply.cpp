// SPDX-License-Identifier: MIT
// The PLY point-cloud reader (src/io/point_cloud.cpp, what `lidarflow viz --points` reads) on
// any file: it either throws lidarflow::Error or returns exactly as many points as the header
// announces and the file holds (27 bytes each, 39 with omx omy omz: then every point has its
// object motion), never failing otherwise (an allocation from a vertex count that wraps was the
// finding this target guards).
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.hpp"
#include "fuzz_support.hpp"
#include "io/point_cloud.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string &path = lidarflow::fuzz::write_scratch(data, size, ".ply");
    try {
        const std::vector<lidarflow::io::CloudPoint> points = lidarflow::io::read_ply(path);
        const std::string text(reinterpret_cast<const char *>(data), size);
        const size_t end = text.find("end_header\n");
        const bool om = !points.empty() && points[0].has_object_motion;
        for (const lidarflow::io::CloudPoint &p : points)
            if (p.has_object_motion != om) std::abort();
        if (end == std::string::npos || size - (end + 11) != points.size() * (om ? 39 : 27)) std::abort();
    } catch (const lidarflow::Error &) {
    }
    return 0;
}
