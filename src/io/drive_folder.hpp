// SPDX-License-Identifier: MIT
#pragma once
// A recorded drive in the KITTI raw layout (docs/SEQUENCES.md), as `lidarflow sequence` reads it:
//   image_02/data/NNNNNNNNNN.png, image_03/data/NNNNNNNNNN.png   left / right image of frame N
//   velodyne_points/data/NNNNNNNNNN.bin                          its Velodyne scan
//   image_02/timestamps.txt                                      optional times (line k: frame k)
// Every file is opened only when it is a regular file and without blocking, and read with a bound
// (core/regular_file.hpp), so a FIFO, device, folder or huge file is a bad frame, not a hang or an
// abort. Functions are thread-compatible (no shared state); results own their data.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "io/velodyne.hpp"

namespace lidarflow::io {

// N as the drive's 10 digits, and frame N's files relative to the drive.
std::string drive_frame_name(long k);
std::string drive_left_file(long k);   // image_02/data/N.png
std::string drive_right_file(long k);  // image_03/data/N.png
std::string drive_scan_file(long k);   // velodyne_points/data/N.bin

// A name in a data folder that starts like a frame's but is not one: its digits are not 10, or
// its extension is not the folder's (00000000003.png, 0000000003.jpg).
struct MisnamedFile {
    std::string file;  // relative to the drive
    long number = -1;  // its leading digits' value; -1 beyond 18 digits
};

struct DriveListing {
    std::vector<long> frames;             // every N with any of its three files listed, sorted
    std::vector<MisnamedFile> misnamed;   // sorted by file
};

// Lists the three data folders (entries are not opened: any kind of entry with a frame's name
// counts, and is reported when its frame is read). Names that do not start with a digit are
// ignored. Throws Error(Io) when image_02/data is not a folder or cannot be listed;
// image_03/data or velodyne_points/data may be missing or unlistable (their files are then tried,
// and reported, frame by frame).
DriveListing list_drive(const std::string &root);

// The drive's image size: the most common header size of the left images of `frames` (ties: the
// earliest frame's), so that one odd frame, the first included, does not make the others odd.
// Unreadable headers do not count; empty when none is readable.
cv::Size drive_frame_size(const std::string &root, const std::vector<long> &frames);

// A bad file (relative to the drive) and why ("missing", "is a FIFO, not a regular file", "is
// 320x80, the drive's frames are 320x96", ...).
struct DriveFileError {
    std::string file;  // empty: no error
    std::string reason;
};

struct DriveFrame {
    cv::Mat left, right;  // 8-bit, gray or BGR, both of one type and of the drive's size
    VelodyneScan scan;    // empty when scan_error says why
    DriveFileError scan_error;
};

// Reads frame k, whose images must be `size`. Returns false and fills `error` for a bad image
// (missing, not a regular file, unreadable, corrupt, of another size or type); a bad scan (the
// same, or too large) leaves the frame good but without points, `frame.scan_error` saying why
// (the frame can still be used image-only). Throws nothing for bad input.
bool read_drive_frame(const std::string &root, long k, cv::Size size, DriveFrame &frame, DriveFileError &error);

// image_02/timestamps.txt in seconds (line k = frame k, "YYYY-MM-DD HH:MM:SS.fffffffff"). The
// times are empty when the file is absent (problem empty) or bad (problem says why: not a regular
// file, larger than kMaxTextFileBytes, a line that does not parse).
struct DriveTimestamps {
    std::vector<double> seconds;
    std::string problem;
};
DriveTimestamps read_drive_timestamps(const std::string &root);

}  // namespace lidarflow::io
