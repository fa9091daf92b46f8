// SPDX-License-Identifier: MIT
#pragma once
// KITTI Velodyne scans (velodyne/ID.bin): a flat array of little-endian float32 records
// (x, y, z, reflectance), x forward, y left, z up [m], in the Velodyne frame.
#include <cstddef>
#include <string>
#include <vector>

namespace lidarflow::io {

struct VelodynePoint {
    float x = 0, y = 0, z = 0;
    float reflectance = 0;
};

struct VelodyneScan {
    std::vector<VelodynePoint> points;  // finite records only, in file order
    std::size_t dropped_nonfinite = 0;  // records with a NaN/inf coordinate or reflectance
};

// Reads a whole .bin file; the scan owns its points. Throws Error: Io when the file cannot be
// opened or read; Format when it is empty, its size is not a multiple of 16 bytes, or no record
// is finite.
VelodyneScan read_velodyne_bin(const std::string &path);

// Writes the points as a .bin file that read_velodyne_bin reads back unchanged (creating
// missing parent folders). Throws Error: InvalidArgument for no points, Io when the file cannot
// be written.
void write_velodyne_bin(const std::string &path, const std::vector<VelodynePoint> &points);

}  // namespace lidarflow::io
