// SPDX-License-Identifier: MIT
#include "io/velodyne.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"

namespace lidarflow::io {

static_assert(sizeof(float) == 4, "Velodyne records are float32");

VelodyneScan read_velodyne_bin(const std::string &path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    require(in.good(), ErrorCode::Io, "cannot open " + path);
    const std::streamoff size = in.tellg();
    require(size >= 0, ErrorCode::Io, "cannot read " + path);
    require(size > 0, ErrorCode::Format, path + ": empty Velodyne scan");
    require(size % 16 == 0, ErrorCode::Format,
            path + ": size " + std::to_string(size) + " bytes is not a multiple of 16 (x, y, z, r float32)");
    std::vector<char> raw(static_cast<std::size_t>(size));
    in.seekg(0);
    in.read(raw.data(), size);
    require(in.gcount() == size, ErrorCode::Io, "cannot read " + path);

    VelodyneScan scan;
    const std::size_t n = raw.size() / 16;
    scan.points.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        float v[4];
        std::memcpy(v, raw.data() + 16 * i, sizeof v);  // memcpy: the buffer has no float alignment
        if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]) || !std::isfinite(v[3])) {
            ++scan.dropped_nonfinite;
            continue;
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
