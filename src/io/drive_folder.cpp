// SPDX-License-Identifier: MIT
#include "io/drive_folder.hpp"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <new>
#include <sstream>

#include "core/error.hpp"
#include "core/regular_file.hpp"
#include "core/size_text.hpp"
#include "io/image_file.hpp"
#include "io/read_file.hpp"

namespace lidarflow::io {
namespace {

namespace fs = std::filesystem;

struct DataFolder {
    const char *dir;
    const char *ext;
};
constexpr DataFolder kFolders[] = {
    {"image_02/data", ".png"}, {"image_03/data", ".png"}, {"velodyne_points/data", ".bin"}};

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Adds `name` of folder `f` to the listing when it starts with digits.
void classify(const std::string &name, const DataFolder &f, DriveListing &out) {
    size_t digits = 0;
    while (digits < name.size() && is_digit(name[digits])) ++digits;
    if (digits == 0) return;
    if (digits == 10 && name.compare(10, std::string::npos, f.ext) == 0) {
        out.frames.push_back(std::stol(name.substr(0, 10)));
        return;
    }
    MisnamedFile m;
    m.file = std::string(f.dir) + "/" + name;
    if (digits <= 18) m.number = std::stol(name.substr(0, digits));
    out.misnamed.push_back(std::move(m));
}

// The reason of an error about `path`: its message without the leading "cannot open PATH: " or
// "PATH: " (the report names the file already).
std::string reason_of(const std::string &message, const std::string &path) {
    for (const std::string &prefix : {"cannot open " + path + ": ", "cannot read " + path + ": ", path + ": "})
        if (message.compare(0, prefix.size(), prefix) == 0) return message.substr(prefix.size());
    return message;
}

cv::Mat read_drive_image(const std::string &path, cv::Size size) {
    cv::Mat m = read_any_image(path);
    require(m.size() == size, ErrorCode::SizeMismatch,
            path + ": is " + size_text(m.size()) + ", the drive's frames are " + size_text(size));
    return m;
}

// Runs `read` on the file `rel` of the drive; false with `error` for whatever the input did.
template <class F>
bool guarded_read(const std::string &root, const std::string &rel, DriveFileError &error, F &&read) {
    const std::string path = (fs::path(root) / rel).string();
    try {
        read(path);
        return true;
    } catch (const Error &e) {
        error = {rel, reason_of(e.what(), path)};
    } catch (const std::bad_alloc &) {
        error = {rel, "out of memory while reading it"};
    } catch (const std::exception &e) {  // OpenCV or the file system, whatever the input did to them
        error = {rel, reason_of(e.what(), path)};
    }
    return false;
}

}  // namespace

std::string drive_frame_name(long k) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "%010ld", k);
    return buf;
}
std::string drive_left_file(long k) { return "image_02/data/" + drive_frame_name(k) + ".png"; }
std::string drive_right_file(long k) { return "image_03/data/" + drive_frame_name(k) + ".png"; }
std::string drive_scan_file(long k) { return "velodyne_points/data/" + drive_frame_name(k) + ".bin"; }

DriveListing list_drive(const std::string &root) {
    DriveListing out;
    for (const DataFolder &f : kFolders) {
        const fs::path dir = fs::path(root) / f.dir;
        std::error_code ec;
        const bool is_dir = fs::is_directory(dir, ec);
        if (&f == &kFolders[0])
            require(is_dir, ErrorCode::Io,
                    "sequence: " + dir.string() + " is not a folder (expected the KITTI raw layout: image_02/data, "
                    "image_03/data, velodyne_points/data)");
        if (!is_dir) continue;
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
            classify(it->path().filename().string(), f, out);
        // The frames come from image_02/data; an unlistable other folder leaves its files to be
        // tried (and reported) frame by frame.
        require(!ec || &f != &kFolders[0], ErrorCode::Io, "sequence: cannot list " + dir.string() + ": " + ec.message());
    }
    std::sort(out.frames.begin(), out.frames.end());
    out.frames.erase(std::unique(out.frames.begin(), out.frames.end()), out.frames.end());
    std::sort(out.misnamed.begin(), out.misnamed.end(),
              [](const MisnamedFile &a, const MisnamedFile &b) { return a.file < b.file; });
    return out;
}

cv::Size drive_frame_size(const std::string &root, const std::vector<long> &frames) {
    std::map<std::pair<int, int>, std::pair<size_t, size_t>> votes;  // size -> (count, first position)
    for (size_t i = 0; i < frames.size(); ++i) {
        try {
            const cv::Size s = read_image_header((fs::path(root) / drive_left_file(frames[i])).string()).size;
            auto &v = votes.try_emplace({s.width, s.height}, std::pair<size_t, size_t>{0, i}).first->second;
            ++v.first;
        } catch (const Error &) {
            // Reported when the frame is read.
        }
    }
    cv::Size best;
    size_t best_count = 0, best_first = 0;
    for (const auto &[s, v] : votes)
        if (v.first > best_count || (v.first == best_count && v.second < best_first)) {
            best = {s.first, s.second};
            best_count = v.first;
            best_first = v.second;
        }
    return best;
}

bool read_drive_frame(const std::string &root, long k, cv::Size size, DriveFrame &frame, DriveFileError &error) {
    frame = DriveFrame{};
    if (!guarded_read(root, drive_left_file(k), error, [&](const std::string &p) { frame.left = read_drive_image(p, size); }) ||
        !guarded_read(root, drive_right_file(k), error, [&](const std::string &p) {
            frame.right = read_drive_image(p, size);
            if (frame.right.type() != frame.left.type())
                throw Error(ErrorCode::Format, std::string("is ") + (frame.right.channels() == 1 ? "gray" : "colour") +
                                                   " but the left image is " +
                                                   (frame.left.channels() == 1 ? "gray" : "colour"));
        }))
        return false;
    guarded_read(root, drive_scan_file(k), frame.scan_error,
                 [&](const std::string &p) { frame.scan = read_velodyne_bin(p); });
    return true;
}

DriveTimestamps read_drive_timestamps(const std::string &root) {
    const std::string path = (fs::path(root) / "image_02" / "timestamps.txt").string();
    DriveTimestamps out;
    RegularFile file(path);
    if (file.missing()) return out;
    std::string text;
    if (!file.read_all(text, kMaxTextFileBytes)) {
        out.problem = file.error();
        return out;
    }
    std::istringstream in(text);
    std::string line;
    for (int lineno = 1; std::getline(in, line); ++lineno) {
        std::tm tm{};
        double sec = 0;
        if (std::sscanf(line.c_str(), "%d-%d-%d %d:%d:%lf", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                        &tm.tm_min, &sec) != 6) {
            out.seconds.clear();
            out.problem = "line " + std::to_string(lineno) + " is not a time (YYYY-MM-DD HH:MM:SS.fffffffff)";
            return out;
        }
        tm.tm_year -= 1900;
        tm.tm_mon -= 1;
        tm.tm_sec = 0;
        out.seconds.push_back(static_cast<double>(timegm(&tm)) + sec);
    }
    return out;
}

}  // namespace lidarflow::io
