// SPDX-License-Identifier: MIT
#include "io/kitti_png.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "core/limits.hpp"

namespace lidarflow::io {
namespace {

// Checks, before anything is decoded, that `path` is a PNG (signature and IHDR chunk) of
// accepted size: cv::imread would decode any format it knows (JPEG 2000, TIFF, ...), each one
// more decoder exposed to the file, and would allocate whatever size the header claims.
cv::Size check_png_header(const std::string &path) {
    std::ifstream in(path, std::ios::binary);
    require(in.good(), ErrorCode::Io, "cannot open " + path);
    unsigned char h[24] = {};
    in.read(reinterpret_cast<char *>(h), sizeof h);
    const size_t got = static_cast<size_t>(in.gcount());
    static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    require(got >= 8 && std::equal(kSignature, kSignature + 8, h), ErrorCode::Format,
            path + ": not a PNG file (no PNG signature)");
    require(got == sizeof h && std::equal(h + 12, h + 16, "IHDR"), ErrorCode::Format,
            path + ": corrupt PNG (no IHDR chunk after the signature)");
    auto be32 = [](const unsigned char *p) {
        return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
    };
    const uint32_t w = be32(h + 16), ht = be32(h + 20);
    require(w > 0 && ht > 0, ErrorCode::Format, path + ": corrupt PNG (zero width or height)");
    constexpr auto max_side = static_cast<uint32_t>(kMaxImageSide);
    require(w <= max_side && ht <= max_side, ErrorCode::InvalidArgument,
            path + " is " + std::to_string(w) + "x" + std::to_string(ht) + ", larger than " +
                std::to_string(kMaxImageSide) + " px per side");
    return {static_cast<int>(w), static_cast<int>(ht)};
}

cv::Mat decode_png(const std::string &path) {
    const cv::Size size = check_png_header(path);
    cv::Mat m = cv::imread(path, cv::IMREAD_UNCHANGED);
    require(!m.empty() && m.size() == size, ErrorCode::Format, path + ": not a readable PNG");
    return m;
}

cv::Mat read_png16(const std::string &path, int channels) {
    cv::Mat m = decode_png(path);
    require(m.depth() == CV_16U && m.channels() == channels, ErrorCode::Format,
            path + ": expected a " + std::to_string(channels) + "-channel 16-bit PNG");
    return m;
}

void ensure_parent(const std::string &path) {
    const auto parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    require(!ec, ErrorCode::Io, "cannot create folder " + parent.string() + ": " + ec.message());
}

void write_or_throw(const std::string &path, const cv::Mat &m) {
    ensure_parent(path);
    bool ok = false;
    try {
        ok = cv::imwrite(path, m);
    } catch (const cv::Exception &e) {
        throw Error(ErrorCode::Io, "cannot write " + path + ": " + e.what());
    }
    require(ok, ErrorCode::Io, "cannot write " + path);
}

uint16_t encode_flow(float f) {
    return static_cast<uint16_t>(std::max(std::min(f * 64.0f + 32768.0f, 65535.0f), 0.0f));
}

}  // namespace

DisparityMap read_disparity_png(const std::string &path) {
    const cv::Mat m = read_png16(path, 1);
    DisparityMap d(m.rows, m.cols);
    for (int y = 0; y < m.rows; ++y) {
        const uint16_t *src = m.ptr<uint16_t>(y);
        float *dst = d[y];
        for (int x = 0; x < m.cols; ++x)
            dst[x] = src[x] == 0 ? kInvalidDisparity : static_cast<float>(src[x]) / 256.0f;
    }
    return d;
}

void write_disparity_png(const std::string &path, const DisparityMap &disp) {
    require(!disp.empty(), ErrorCode::InvalidArgument, "empty disparity map for " + path);
    cv::Mat m(disp.rows, disp.cols, CV_16UC1);
    for (int y = 0; y < disp.rows; ++y) {
        const float *src = disp[y];
        uint16_t *dst = m.ptr<uint16_t>(y);
        for (int x = 0; x < disp.cols; ++x) {
            const float d = src[x];
            // NaN fails disparity_valid and is written as invalid, never as garbage.
            dst[x] = disparity_valid(d)
                         ? static_cast<uint16_t>(std::min(std::max(d * 256.0, 1.0), 65535.0))
                         : 0;
        }
    }
    write_or_throw(path, m);
}

FlowField read_flow_png(const std::string &path) {
    const cv::Mat m = read_png16(path, 3);
    FlowField f = FlowField::zeros(m.cols, m.rows);
    for (int y = 0; y < m.rows; ++y) {
        const cv::Vec3w *src = m.ptr<cv::Vec3w>(y);  // OpenCV order: B = valid, G = v, R = u
        for (int x = 0; x < m.cols; ++x) {
            if (src[x][0] == 0) continue;
            f.u(y, x) = (static_cast<float>(src[x][2]) - 32768.0f) / 64.0f;
            f.v(y, x) = (static_cast<float>(src[x][1]) - 32768.0f) / 64.0f;
            f.valid(y, x) = 1;
        }
    }
    return f;
}

void write_flow_png(const std::string &path, const FlowField &flow) {
    require(!flow.u.empty() && flow.u.size() == flow.v.size() && flow.u.size() == flow.valid.size(),
            ErrorCode::SizeMismatch, "flow planes differ in size for " + path);
    cv::Mat m(flow.height(), flow.width(), CV_16UC3);
    for (int y = 0; y < m.rows; ++y) {
        cv::Vec3w *dst = m.ptr<cv::Vec3w>(y);
        for (int x = 0; x < m.cols; ++x) {
            const float u = flow.u(y, x), v = flow.v(y, x);
            if (flow.valid(y, x) && std::isfinite(u) && std::isfinite(v))
                dst[x] = cv::Vec3w(1, encode_flow(v), encode_flow(u));
            else
                dst[x] = cv::Vec3w(0, 0, 0);
        }
    }
    write_or_throw(path, m);
}

cv::Mat read_image(const std::string &path) {
    cv::Mat m = decode_png(path);
    require(m.depth() == CV_8U && (m.channels() == 1 || m.channels() == 3), ErrorCode::Format,
            path + ": expected an 8-bit gray or colour image");
    return m;
}

void write_image(const std::string &path, const cv::Mat &image) {
    require(!image.empty(), ErrorCode::InvalidArgument, "empty image for " + path);
    write_or_throw(path, image);
}

}  // namespace lidarflow::io
