// SPDX-License-Identifier: MIT
#pragma once
// KITTI disparity and flow PNG codecs, bit-exact with the official devkit (io_disp.h,
// io_flow.h):
//  - disparity: 1 x uint16, d = value / 256, value 0 = invalid; written as
//    max(d * 256, 1) truncated to uint16 (so a valid 0 survives as 1/256);
//  - flow: 3 x uint16 (R, G, B) = (u * 64 + 2^15, v * 64 + 2^15, valid), clamped to
//    [0, 65535] and truncated; invalid pixels are written as (0, 0, 0).
// All functions throw lidarflow::Error (Io: cannot open/write; Format: not a PNG, checked by
// its signature before anything is decoded, or the wrong PNG type; InvalidArgument: a side
// larger than kMaxImageSide of core/limits.hpp, read from the header before decoding).
#include <string>

#include "core/maps.hpp"

namespace lidarflow::io {

DisparityMap read_disparity_png(const std::string &path);
void write_disparity_png(const std::string &path, const DisparityMap &disp);

FlowField read_flow_png(const std::string &path);
void write_flow_png(const std::string &path, const FlowField &flow);

// 8-bit PNG image as stored (gray or BGR); Io when unreadable, Format when not a PNG or not
// 8-bit, InvalidArgument when too large.
cv::Mat read_image(const std::string &path);
// Creates missing parent folders; Io on failure.
void write_image(const std::string &path, const cv::Mat &image);

}  // namespace lidarflow::io
