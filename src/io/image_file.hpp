// SPDX-License-Identifier: MIT
#pragma once
// 8-bit camera images in the common formats OpenCV reads: PNG, JPEG, BMP and binary/ASCII
// PNM (PGM, PPM). The format is told by the file's signature (not its name) and the size read
// from its header before anything is decoded, so a header claiming a huge image is refused
// without allocating it, and no other decoder of OpenCV (TIFF, JPEG 2000, OpenEXR, ...) is ever
// handed a file. io::read_image (KITTI layouts) stays PNG-only.
#include <string>

#include <opencv2/core.hpp>

namespace lidarflow::io {

// The format name ("PNG", "JPEG", "BMP", "PNM") and size from the header; throws Error: Io when
// the file cannot be opened or is not a regular file (a FIFO, a device, a folder: never waited on), Format when it is none of those formats or its header is corrupt,
// InvalidArgument when a side exceeds kMaxImageSide (core/limits.hpp).
struct ImageHeader {
    std::string format;
    cv::Size size;
};
ImageHeader read_image_header(const std::string &path);

// The image as stored, gray (CV_8UC1) or BGR (CV_8UC3); Format when it decodes to another depth
// or channel count (16-bit PNG, alpha) or to another size than its header announced.
cv::Mat read_any_image(const std::string &path);

}  // namespace lidarflow::io
