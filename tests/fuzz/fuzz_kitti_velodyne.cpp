// SPDX-License-Identifier: MIT
// The KITTI Velodyne reader (src/io/velodyne.cpp) through a scratch file. It either throws
// lidarflow::Error or returns finite records that, with the dropped ones, are all of the file.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "core/error.hpp"
#include "fuzz_support.hpp"
#include "io/velodyne.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string &path = lidarflow::fuzz::write_scratch(data, size, ".bin");
    try {
        const lidarflow::io::VelodyneScan scan = lidarflow::io::read_velodyne_bin(path);
        if (size % 16 != 0 || scan.points.empty() || scan.points.size() + scan.dropped_nonfinite != size / 16)
            std::abort();
        for (const auto &p : scan.points)
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.reflectance))
                std::abort();
    } catch (const lidarflow::Error &) {
    }
    return 0;
}
