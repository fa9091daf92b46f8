// SPDX-License-Identifier: MIT
#pragma once
// KITTI Velodyne scans (velodyne/ID.bin): a flat array of little-endian float32 records
// (x, y, z, reflectance), x forward, y left, z up [m], in the Velodyne frame.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lidarflow::io {

struct VelodynePoint {
    float x = 0, y = 0, z = 0;
    float reflectance = 0;
};

struct VelodyneScan {
    std::vector<VelodynePoint> points;      // records with finite x, y, z, in file order
    std::size_t dropped_nonfinite = 0;      // records with a NaN/inf coordinate (dropped)
    std::size_t nonfinite_reflectance = 0;  // kept records whose NaN/inf reflectance reads as 0
};

// The largest scan read: 4 Mi points, some 30 times a 64-ring spinning LiDAR's.
constexpr std::uint64_t kMaxVelodyneBytes = std::uint64_t{64} << 20;

// Reads a whole .bin file; the scan owns its points. Only a regular file is opened, without
// blocking (core/regular_file.hpp). Throws Error: Io when the file cannot be opened (missing, a
// folder, a FIFO, ... as the message says) or read; Format when it is empty, its size is not a
// multiple of 16 bytes or above kMaxVelodyneBytes (refused before anything is allocated), or no
// record has a finite x, y, z.
VelodyneScan read_velodyne_bin(const std::string &path);

// Writes the points as a .bin file that read_velodyne_bin reads back unchanged (creating
// missing parent folders). Throws Error: InvalidArgument for no points, Io when the file cannot
// be written.
void write_velodyne_bin(const std::string &path, const std::vector<VelodynePoint> &points);

}  // namespace lidarflow::io
