// SPDX-License-Identifier: MIT
#include "io/velodyne.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "core/regular_file.hpp"

namespace lidarflow::io {

static_assert(sizeof(float) == 4, "Velodyne records are float32");

VelodyneScan read_velodyne_bin(const std::string &path) {
    RegularFile file(path);
    require(file.ok(), ErrorCode::Io, [&] { return "cannot open " + path + ": " + file.error(); });
    const uint64_t size = file.size();
    require(size > 0, ErrorCode::Format, path + ": empty Velodyne scan");
    require(size % 16 == 0, ErrorCode::Format,
            path + ": size " + std::to_string(size) + " bytes is not a multiple of 16 (x, y, z, r float32)");
    require(size <= kMaxVelodyneBytes, ErrorCode::Format, [&] {
        return path + ": size " + std::to_string(size) + " bytes is more than a scan's " +
               std::to_string(kMaxVelodyneBytes) + " (" + std::to_string(kMaxVelodyneBytes / 16) + " points)";
    });
    std::string raw;
    require(file.read_all(raw, kMaxVelodyneBytes), ErrorCode::Io, [&] { return "cannot read " + path + ": " + file.error(); });
    require(raw.size() == size, ErrorCode::Io, path + ": changed while read");

    VelodyneScan scan;
    const std::size_t n = raw.size() / 16;
    scan.points.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        float v[4];
        std::memcpy(v, raw.data() + 16 * i, sizeof v);  // memcpy: the buffer has no float alignment
        if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
            ++scan.dropped_nonfinite;
            continue;
        }
        // The position is what places the point; a broken reflectance is not a reason to lose it.
        if (!std::isfinite(v[3])) {
            ++scan.nonfinite_reflectance;
            v[3] = 0;
        }
        scan.points.push_back({v[0], v[1], v[2], v[3]});
    }
    require(!scan.points.empty(), ErrorCode::Format, path + ": no finite point in the Velodyne scan");
    return scan;
}

void write_velodyne_bin(const std::string &path, const std::vector<VelodynePoint> &points) {
    require(!points.empty(), ErrorCode::InvalidArgument, path + ": a Velodyne scan needs at least one point");
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    std::vector<char> raw(points.size() * 16);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const float v[4] = {points[i].x, points[i].y, points[i].z, points[i].reflectance};
        std::memcpy(raw.data() + 16 * i, v, sizeof v);
    }
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(raw.data(), static_cast<std::streamsize>(raw.size()));
    out.close();
    require(out.good(), ErrorCode::Io, "cannot write " + path);
}

}  // namespace lidarflow::io
