// SPDX-License-Identifier: MIT
#include "io/image_file.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "core/regular_file.hpp"

namespace lidarflow::io {
namespace {

uint32_t be16(const unsigned char *p) { return (uint32_t(p[0]) << 8) | uint32_t(p[1]); }
uint32_t be32(const unsigned char *p) { return (be16(p) << 16) | be16(p + 2); }
uint32_t le32(const unsigned char *p) {
    return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

[[noreturn]] void corrupt(const std::string &path, const std::string &format, const std::string &why) {
    throw Error(ErrorCode::Format, path + ": corrupt " + format + " (" + why + ")");
}

cv::Size png_size(std::ifstream &in, const std::string &path) {
    unsigned char h[24] = {};
    in.read(reinterpret_cast<char *>(h), sizeof h);
    if (in.gcount() != sizeof h || std::memcmp(h + 12, "IHDR", 4) != 0)
        corrupt(path, "PNG", "no IHDR chunk after the signature");
    return {static_cast<int>(std::min<uint32_t>(be32(h + 16), INT32_MAX)),
            static_cast<int>(std::min<uint32_t>(be32(h + 20), INT32_MAX))};
}

// The frame header (SOFn) among the segments after SOI.
cv::Size jpeg_size(std::ifstream &in, const std::string &path) {
    in.seekg(2);
    for (int segments = 0; segments < 4096; ++segments) {
        int c = in.get();
        if (c != 0xFF) corrupt(path, "JPEG", "no marker where one is expected");
        while (c == 0xFF) c = in.get();  // fill bytes
        if (c == EOF) break;
        if (c == 0xD8 || c == 0x01 || (c >= 0xD0 && c <= 0xD7)) continue;  // no length
        if (c == 0xD9 || c == 0xDA) corrupt(path, "JPEG", "no frame header before the image data");
        unsigned char len[2];
        if (!in.read(reinterpret_cast<char *>(len), 2)) break;
        const uint32_t n = be16(len);
        if (n < 2) corrupt(path, "JPEG", "segment length below 2");
        const bool sof = c >= 0xC0 && c <= 0xCF && c != 0xC4 && c != 0xC8 && c != 0xCC;
        if (sof) {
            unsigned char f[5];
            if (n < 7 || !in.read(reinterpret_cast<char *>(f), 5)) corrupt(path, "JPEG", "short frame header");
            return {static_cast<int>(be16(f + 3)), static_cast<int>(be16(f + 1))};
        }
        in.seekg(n - 2, std::ios::cur);
    }
    corrupt(path, "JPEG", "no frame header");
}

cv::Size bmp_size(std::ifstream &in, const std::string &path) {
    unsigned char h[26] = {};
    in.read(reinterpret_cast<char *>(h), sizeof h);
    if (in.gcount() != sizeof h) corrupt(path, "BMP", "short header");
    const uint32_t dib = le32(h + 14);
    if (dib == 12) {  // OS/2 BITMAPCOREHEADER: 16-bit sides
        return {static_cast<int>(h[18] | (h[19] << 8)), static_cast<int>(h[20] | (h[21] << 8))};
    }
    if (dib < 40) corrupt(path, "BMP", "unknown DIB header");
    const auto w = static_cast<int32_t>(le32(h + 18)), ht = static_cast<int32_t>(le32(h + 22));
    // A negative height is a top-down bitmap.
    const int64_t ah = ht < 0 ? -int64_t(ht) : int64_t(ht);
    return {static_cast<int>(std::max<int64_t>(std::min<int64_t>(w, INT32_MAX), -1)),
            static_cast<int>(std::min<int64_t>(ah, INT32_MAX))};
}

// P2, P3, P5, P6: width, height (and maxval) as text, '#' comments allowed.
cv::Size pnm_size(std::ifstream &in, const std::string &path) {
    in.seekg(2);
    long v[2] = {0, 0};
    for (long &x : v) {
        int c = in.get();
        while (c != EOF && (std::isspace(c) || c == '#')) {
            if (c == '#')
                while (c != EOF && c != '\n') c = in.get();
            c = in.get();
        }
        if (c == EOF || !std::isdigit(c)) corrupt(path, "PNM", "no size in the header");
        for (int digits = 0; c != EOF && std::isdigit(c); c = in.get(), ++digits) {
            if (digits > 9) corrupt(path, "PNM", "size out of range");
            x = 10 * x + (c - '0');
        }
    }
    return {static_cast<int>(v[0]), static_cast<int>(v[1])};
}

}  // namespace

ImageHeader read_image_header(const std::string &path) {
    // Regular files only: opening a FIFO would wait for a writer, a device be read without end.
    const RegularFile file(path);
    require(file.ok(), ErrorCode::Io, [&] { return "cannot open " + path + ": " + file.error(); });
    std::ifstream in(path, std::ios::binary);
    require(in.good(), ErrorCode::Io, "cannot open " + path);
    unsigned char sig[8] = {};
    in.read(reinterpret_cast<char *>(sig), sizeof sig);
    const auto got = static_cast<size_t>(in.gcount());
    in.clear();
    in.seekg(0);
    static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    ImageHeader h;
    if (got >= 8 && std::memcmp(sig, kPng, 8) == 0) {
        h = {"PNG", png_size(in, path)};
    } else if (got >= 3 && sig[0] == 0xFF && sig[1] == 0xD8 && sig[2] == 0xFF) {
        h = {"JPEG", jpeg_size(in, path)};
    } else if (got >= 2 && sig[0] == 'B' && sig[1] == 'M') {
        h = {"BMP", bmp_size(in, path)};
    } else if (got >= 3 && sig[0] == 'P' && std::strchr("2356", sig[1]) && std::isspace(sig[2])) {
        h = {"PNM", pnm_size(in, path)};
    } else {
        throw Error(ErrorCode::Format, path + ": not an image file this reads (PNG, JPEG, BMP, PGM/PPM; by signature)");
    }
    require(h.size.width > 0 && h.size.height > 0, ErrorCode::Format,
            path + ": corrupt " + h.format + " (zero or negative width or height)");
    require(h.size.width <= kMaxImageSide && h.size.height <= kMaxImageSide, ErrorCode::InvalidArgument,
            path + " is " + std::to_string(h.size.width) + "x" + std::to_string(h.size.height) + ", larger than " +
                std::to_string(kMaxImageSide) + " px per side");
    return h;
}

cv::Mat read_any_image(const std::string &path) {
    const ImageHeader h = read_image_header(path);
    // Header checked: only now does a decoder see the file. IMREAD_UNCHANGED keeps gray gray and
    // ignores EXIF orientation, so the pixels are the camera's.
    cv::Mat m;
    try {
        m = cv::imread(path, cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception &e) {
        throw Error(ErrorCode::Format, path + ": not a readable " + h.format + ": " + e.what());
    }
    require(!m.empty() && m.size() == h.size, ErrorCode::Format, path + ": not a readable " + h.format);
    require(m.depth() == CV_8U && (m.channels() == 1 || m.channels() == 3), ErrorCode::Format,
            path + ": expected an 8-bit gray or colour image");
    return m;
}

}  // namespace lidarflow::io
