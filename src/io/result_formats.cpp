// SPDX-License-Identifier: MIT
#include "io/result_formats.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <opencv2/video/tracking.hpp>

#include "core/closest_name.hpp"
#include "core/error.hpp"
#include "core/limits.hpp"
#include "io/kitti_png.hpp"
#include "io/kitti_submission.hpp"
#include "io/read_file.hpp"

namespace lidarflow::io {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Middlebury's "unknown flow" value; its readers test |value| > 1e9.
constexpr float kFloUnknown = 1e10f;
constexpr float kFloUnknownThreshold = 1e9f;

void check_float_map(const cv::Mat &map, const std::string &path) {
    require(!map.empty(), ErrorCode::InvalidArgument, "empty map for " + path);
    require(map.type() == CV_32FC1 || map.type() == CV_32FC3, ErrorCode::InvalidArgument,
            path + ": expected a float32 map with 1 or 3 channels");
}

std::ofstream open_for_writing(const std::string &path) {
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    require(out.good(), ErrorCode::Io, "cannot write " + path);
    return out;
}

void finish(std::ofstream &out, const std::string &path) {
    out.flush();
    require(out.good(), ErrorCode::Io, "cannot write " + path);
}

// Byte order made explicit so the files are the same on any host.
void put_le32(std::string &buf, float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int k = 0; k < 4; ++k) buf.push_back(static_cast<char>((u >> (8 * k)) & 0xffu));
}

float get32(const char *p, bool little) {
    uint32_t u = 0;
    for (int k = 0; k < 4; ++k) {
        const uint32_t byte = static_cast<unsigned char>(p[little ? k : 3 - k]);
        u |= byte << (8 * k);
    }
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

// The whole file as float32 values once the header is consumed.
void read_floats(const std::string &data, size_t offset, cv::Mat &m, bool little, bool bottom_up,
                 const std::string &path) {
    const size_t n = m.total() * static_cast<size_t>(m.channels());
    require(data.size() - offset == 4 * n, ErrorCode::Format,
            path + ": " + std::to_string(data.size() - offset) + " bytes of data, the header announces " +
                std::to_string(4 * n));
    const size_t row = static_cast<size_t>(m.cols) * static_cast<size_t>(m.channels());
    for (int y = 0; y < m.rows; ++y) {
        float *dst = m.ptr<float>(bottom_up ? m.rows - 1 - y : y);
        const char *src = data.data() + offset + 4 * row * static_cast<size_t>(y);
        for (size_t k = 0; k < row; ++k) dst[k] = get32(src + 4 * k, little);
    }
}

// Checks, before anything is allocated, that a header's size is accepted (kMaxImageSide per side)
// and that the file holds exactly the bytes it announces: a corrupt or hostile header is a
// Format error, never a huge allocation.
void check_payload(const std::string &path, long w, long h, int channels, size_t bytes_per_value,
                   size_t payload) {
    require(w > 0 && h > 0, ErrorCode::Format,
            path + ": bad size " + std::to_string(w) + "x" + std::to_string(h) + " in the header");
    require(w <= kMaxImageSide && h <= kMaxImageSide, ErrorCode::Format,
            path + ": the header announces " + std::to_string(w) + "x" + std::to_string(h) + ", larger than " +
                std::to_string(kMaxImageSide) + " px per side");
    const size_t expected = static_cast<size_t>(w) * static_cast<size_t>(h) * static_cast<size_t>(channels) *
                            bytes_per_value;
    require(payload == expected, ErrorCode::Format,
            path + ": " + std::to_string(payload) + " bytes of data, the header announces " + std::to_string(expected) +
                " (" + std::to_string(w) + "x" + std::to_string(h) + "x" + std::to_string(channels) + ")");
}

std::string lower_extension(const std::string &path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char &c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

// Parses "H, W" or "H, W, C" of a .npy shape tuple.
std::vector<long> parse_shape(const std::string &tuple) {
    std::vector<long> dims;
    std::stringstream ss(tuple);
    std::string item;
    while (std::getline(ss, item, ',')) {
        const size_t a = item.find_first_not_of(" ");
        if (a == std::string::npos) continue;
        char *end = nullptr;
        const long v = std::strtol(item.c_str() + a, &end, 10);
        if (*end != '\0' && *end != ' ') return {};
        dims.push_back(v);
    }
    return dims;
}

}  // namespace

const char *result_format_name(ResultFormat f) {
    switch (f) {
    case ResultFormat::Kitti: return "kitti";
    case ResultFormat::Flo: return "flo";
    case ResultFormat::Pfm: return "pfm";
    case ResultFormat::Npy: return "npy";
    }
    return "unknown";
}

ResultFormat parse_result_format(const std::string &name) {
    const ResultFormat all[] = {ResultFormat::Kitti, ResultFormat::Flo, ResultFormat::Pfm, ResultFormat::Npy};
    std::vector<std::string> names;
    for (ResultFormat f : all) {
        if (name == result_format_name(f)) return f;
        names.push_back(result_format_name(f));
    }
    throw Error(ErrorCode::InvalidArgument,
                "unknown result format '" + name + "'" + did_you_mean(name, names) + " (kitti, flo, pfm, npy)");
}

cv::Mat1f disparity_with_nan(const DisparityMap &disp) {
    cv::Mat1f out(disp.size());
    for (int y = 0; y < disp.rows; ++y)
        for (int x = 0; x < disp.cols; ++x) {
            const float d = disp(y, x);
            out(y, x) = disparity_valid(d) ? d : kNaN;
        }
    return out;
}

cv::Mat3f flow_with_valid(const FlowField &flow) {
    cv::Mat3f out(flow.u.size());
    for (int y = 0; y < out.rows; ++y)
        for (int x = 0; x < out.cols; ++x) {
            const float u = flow.u(y, x), v = flow.v(y, x);
            const bool ok = flow.valid(y, x) && std::isfinite(u) && std::isfinite(v);
            out(y, x) = ok ? cv::Vec3f(u, v, 1.0f) : cv::Vec3f(kNaN, kNaN, 0.0f);
        }
    return out;
}

cv::Mat2f flow_with_nan(const FlowField &flow) {
    cv::Mat2f out(flow.u.size());
    for (int y = 0; y < out.rows; ++y)
        for (int x = 0; x < out.cols; ++x) {
            const float u = flow.u(y, x), v = flow.v(y, x);
            const bool ok = flow.valid(y, x) && std::isfinite(u) && std::isfinite(v);
            out(y, x) = ok ? cv::Vec2f(u, v) : cv::Vec2f(kNaN, kNaN);
        }
    return out;
}

void write_pfm(const std::string &path, const cv::Mat &map) {
    check_float_map(map, path);
    // Scale -1: little-endian data, which is how every PFM reader in use expects it.
    std::string buf = std::string(map.channels() == 3 ? "PF" : "Pf") + "\n" + std::to_string(map.cols) + " " +
                      std::to_string(map.rows) + "\n-1.0\n";
    const size_t row = static_cast<size_t>(map.cols) * static_cast<size_t>(map.channels());
    buf.reserve(buf.size() + 4 * row * static_cast<size_t>(map.rows));
    for (int y = map.rows - 1; y >= 0; --y) {
        const float *src = map.ptr<float>(y);
        for (size_t k = 0; k < row; ++k) put_le32(buf, src[k]);
    }
    std::ofstream out = open_for_writing(path);
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    finish(out, path);
}

cv::Mat read_pfm(const std::string &path) {
    const std::string data = read_file(path);
    // Header: three whitespace-separated tokens after the magic, then exactly one whitespace byte.
    size_t pos = 0;
    auto token = [&]() {
        while (pos < data.size() && std::isspace(static_cast<unsigned char>(data[pos]))) ++pos;
        const size_t a = pos;
        while (pos < data.size() && !std::isspace(static_cast<unsigned char>(data[pos]))) ++pos;
        return data.substr(a, pos - a);
    };
    const std::string magic = token();
    require(magic == "PF" || magic == "Pf", ErrorCode::Format, path + ": not a PFM file (magic '" + magic + "')");
    const std::string ws = token(), hs = token(), ss = token();
    require(pos < data.size(), ErrorCode::Format, path + ": truncated PFM header");
    ++pos;
    char *end = nullptr;
    const long w = std::strtol(ws.c_str(), &end, 10);
    const bool w_ok = !ws.empty() && *end == '\0';
    const long h = std::strtol(hs.c_str(), &end, 10);
    const bool h_ok = !hs.empty() && *end == '\0';
    const double scale = std::strtod(ss.c_str(), &end);
    const bool s_ok = !ss.empty() && *end == '\0' && std::isfinite(scale) && scale != 0;
    require(w_ok && h_ok && s_ok, ErrorCode::Format, path + ": bad PFM header '" + ws + " " + hs + " " + ss + "'");
    check_payload(path, w, h, magic == "PF" ? 3 : 1, 4, data.size() - pos);
    cv::Mat m(static_cast<int>(h), static_cast<int>(w), magic == "PF" ? CV_32FC3 : CV_32FC1);
    read_floats(data, pos, m, scale < 0, true, path);
    return m;
}

void write_npy(const std::string &path, const cv::Mat &map) {
    require(!map.empty(), ErrorCode::InvalidArgument, "empty map for " + path);
    const int type = map.type();
    require(type == CV_32FC1 || type == CV_32FC2 || type == CV_32FC3 || type == CV_8UC1, ErrorCode::InvalidArgument,
            path + ": expected a float32 map with 1 to 3 channels or a uint8 map");
    const bool bytes = type == CV_8UC1;
    std::string header = std::string("{'descr': '") + (bytes ? "|u1" : "<f4") + "', 'fortran_order': False, 'shape': (" +
                         std::to_string(map.rows) + ", " + std::to_string(map.cols) +
                         (map.channels() > 1 ? ", " + std::to_string(map.channels()) : std::string()) + "), }";
    // Magic (6) + version (2) + length (2) + header, padded with spaces and ended by '\n' to a
    // multiple of 64 bytes, as numpy writes it.
    const size_t total = (10 + header.size() + 1 + 63) / 64 * 64;
    header.resize(total - 10 - 1, ' ');
    header.push_back('\n');
    std::string buf = std::string("\x93NUMPY\x01\x00", 8);
    buf.push_back(static_cast<char>(header.size() & 0xff));
    buf.push_back(static_cast<char>(header.size() >> 8));
    buf += header;
    const size_t row = static_cast<size_t>(map.cols) * static_cast<size_t>(map.channels());
    for (int y = 0; y < map.rows; ++y) {
        if (bytes) {
            buf.append(map.ptr<char>(y), row);
            continue;
        }
        const float *src = map.ptr<float>(y);
        for (size_t k = 0; k < row; ++k) put_le32(buf, src[k]);
    }
    std::ofstream out = open_for_writing(path);
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    finish(out, path);
}

cv::Mat read_npy(const std::string &path) {
    const std::string data = read_file(path);
    require(data.size() >= 10 && data.compare(0, 6, "\x93NUMPY") == 0, ErrorCode::Format,
            path + ": not a .npy file");
    require(data[6] == 1 && data[7] == 0, ErrorCode::Format, path + ": only .npy version 1.0 is read");
    const size_t len = static_cast<unsigned char>(data[8]) | static_cast<size_t>(static_cast<unsigned char>(data[9])) << 8;
    require(data.size() >= 10 + len, ErrorCode::Format, path + ": truncated .npy header");
    const std::string header = data.substr(10, len);
    auto value_of = [&](const std::string &key) {
        const size_t k = header.find("'" + key + "':");
        require(k != std::string::npos, ErrorCode::Format, path + ": .npy header has no '" + key + "'");
        size_t a = k + key.size() + 3;
        while (a < header.size() && header[a] == ' ') ++a;
        return a;
    };
    const size_t d = value_of("descr");
    const bool bytes = header.compare(d, 5, "'|u1'") == 0;
    require(bytes || header.compare(d, 5, "'<f4'") == 0, ErrorCode::Format,
            path + ": expected little-endian float32 ('<f4') or uint8 ('|u1')");
    const size_t f = value_of("fortran_order");
    require(header.compare(f, 5, "False") == 0, ErrorCode::Format, path + ": Fortran-order arrays are not read");
    const size_t s = value_of("shape");
    const size_t close = header.find(')', s);
    require(header[s] == '(' && close != std::string::npos, ErrorCode::Format, path + ": bad .npy shape");
    const std::vector<long> dims = parse_shape(header.substr(s + 1, close - s - 1));
    const bool ok = dims.size() == 2 || (!bytes && dims.size() == 3 && (dims[2] == 2 || dims[2] == 3));
    require(ok, ErrorCode::Format,
            path + (bytes ? ": expected a uint8 (H, W) shape" : ": expected shape (H, W), (H, W, 2) or (H, W, 3)"));
    const int channels = dims.size() == 3 ? static_cast<int>(dims[2]) : 1;
    check_payload(path, dims[1], dims[0], channels, bytes ? 1 : 4, data.size() - 10 - len);
    cv::Mat m(static_cast<int>(dims[0]), static_cast<int>(dims[1]), bytes ? CV_8UC1 : CV_32FC(channels));
    if (bytes)
        for (int y = 0; y < m.rows; ++y)
            std::memcpy(m.ptr(y), data.data() + 10 + len + static_cast<size_t>(y) * m.cols, static_cast<size_t>(m.cols));
    else
        read_floats(data, 10 + len, m, true, false, path);
    return m;
}

void write_flo(const std::string &path, const FlowField &flow) {
    require(!flow.u.empty(), ErrorCode::InvalidArgument, "empty flow for " + path);
    cv::Mat2f uv(flow.u.size());
    for (int y = 0; y < uv.rows; ++y)
        for (int x = 0; x < uv.cols; ++x) {
            const float u = flow.u(y, x), v = flow.v(y, x);
            const bool ok = flow.valid(y, x) && std::isfinite(u) && std::isfinite(v);
            uv(y, x) = ok ? cv::Vec2f(u, v) : cv::Vec2f(kFloUnknown, kFloUnknown);
        }
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    require(cv::writeOpticalFlow(path, uv), ErrorCode::Io, "cannot write " + path);
}

FlowField read_flo(const std::string &path) {
    // Read here rather than by cv::readOpticalFlow, which allocates whatever size the header
    // claims before it finds the data missing.
    const std::string data = read_file(path);
    require(data.size() >= 12 && data.compare(0, 4, "PIEH") == 0, ErrorCode::Format,
            path + ": not a .flo file (no PIEH tag)");
    auto le32 = [&](size_t at) {
        uint32_t u = 0;
        for (int k = 0; k < 4; ++k) u |= static_cast<uint32_t>(static_cast<unsigned char>(data[at + k])) << (8 * k);
        return static_cast<int32_t>(u);
    };
    const long w = le32(4), h = le32(8);
    check_payload(path, w, h, 2, 4, data.size() - 12);
    FlowField f = FlowField::zeros(static_cast<int>(w), static_cast<int>(h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const char *p = data.data() + 12 + 8 * (static_cast<size_t>(y) * static_cast<size_t>(w) + x);
            const float u = get32(p, true), v = get32(p + 4, true);
            const bool ok = std::fabs(u) <= kFloUnknownThreshold && std::fabs(v) <= kFloUnknownThreshold;
            f.u(y, x) = ok ? u : 0.0f;
            f.v(y, x) = ok ? v : 0.0f;
            f.valid(y, x) = ok ? 1 : 0;
        }
    return f;
}

DisparityMap read_disparity_file(const std::string &path) {
    const std::string ext = lower_extension(path);
    if (ext == ".pfm" || ext == ".npy") {
        const cv::Mat m = ext == ".pfm" ? read_pfm(path) : read_npy(path);
        require(m.depth() == CV_32F, ErrorCode::Format, path + ": a disparity map is float32, this file is uint8");
        require(m.type() == CV_32FC1, ErrorCode::Format,
                path + ": a disparity map has one channel, this file has " + std::to_string(m.channels()));
        DisparityMap d(m.rows, m.cols);
        for (int y = 0; y < m.rows; ++y)
            for (int x = 0; x < m.cols; ++x) {
                const float v = m.at<float>(y, x);
                d(y, x) = std::isfinite(v) && disparity_valid(v) ? v : kInvalidDisparity;
            }
        return d;
    }
    require(ext == ".png", ErrorCode::Format,
            path + ": unknown disparity file type '" + ext + "' (.png KITTI, .pfm, .npy)");
    return read_disparity_png(path);
}

FlowField read_flow_file(const std::string &path) {
    const std::string ext = lower_extension(path);
    if (ext == ".flo") return read_flo(path);
    if (ext == ".pfm" || ext == ".npy") {
        const cv::Mat m = ext == ".pfm" ? read_pfm(path) : read_npy(path);
        require(m.depth() == CV_32F, ErrorCode::Format, path + ": flow is float32, this file is uint8");
        require(m.channels() >= 2, ErrorCode::Format,
                path + ": flow has (u, v) or (u, v, valid) per pixel, this file has one channel");
        FlowField f = FlowField::zeros(m.cols, m.rows);
        for (int y = 0; y < m.rows; ++y)
            for (int x = 0; x < m.cols; ++x) {
                const float *p = m.ptr<float>(y) + static_cast<size_t>(x) * m.channels();
                const bool ok = std::isfinite(p[0]) && std::isfinite(p[1]) && (m.channels() == 2 || p[2] != 0.0f);
                if (!ok) continue;
                f.u(y, x) = p[0];
                f.v(y, x) = p[1];
                f.valid(y, x) = 1;
            }
        return f;
    }
    require(ext == ".png", ErrorCode::Format,
            path + ": unknown flow file type '" + ext + "' (.png KITTI, .flo, .pfm, .npy)");
    return read_flow_png(path);
}

void check_output_name(const std::string &name) {
    bool ok = !name.empty() && name.size() <= 128 && name != "." && name != "..";
    for (char c : name)
        ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.');
    require(ok, ErrorCode::InvalidArgument,
            "output name '" + name + "' must be 1 to 128 of A-Z a-z 0-9 _ - . (and not . or ..)");
}

std::string result_file_stem(const std::string &name) {
    check_output_name(name);
    const bool kitti_id = name.size() == 6 && std::all_of(name.begin(), name.end(), [](char c) {
                              return c >= '0' && c <= '9';
                          });
    return kitti_id ? name + "_10" : name;
}

std::string output_name_from_path(const std::string &path) {
    std::string stem = std::filesystem::path(path).stem().string();
    // A KITTI image name (000002_10.png): the frame id, so the results keep KITTI's names.
    const bool kitti_image = stem.size() == 9 && stem.compare(6, 3, "_10") == 0 &&
                             std::all_of(stem.begin(), stem.begin() + 6, [](char c) { return c >= '0' && c <= '9'; });
    if (kitti_image) stem.resize(6);
    for (char &c : stem)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) c = '_';
    if (stem.size() > 128) stem.resize(128);
    if (stem.empty() || stem == "." || stem == "..") stem = "result";
    return stem;
}

cv::Mat1f confidence_map(const SceneFlowField &f) {
    cv::Mat1f c(f.confidence.size(), 0.0f);
    f.confidence.copyTo(c, f.valid);
    return c;
}

std::vector<std::string> result_paths(const std::string &out_root, const std::string &id, ResultFormat format) {
    const std::string stem = result_file_stem(id);
    auto path = [&](const char *folder, const char *ext) { return out_root + "/" + folder + "/" + stem + "." + ext; };
    if (format == ResultFormat::Kitti) return {path("disp_0", "png"), path("disp_1", "png"), path("flow", "png")};
    if (format == ResultFormat::Npy)  // flow (H, W, 2) with NaN holes, its validity apart
        return {path("disp_0", "npy"), path("disp_1", "npy"), path("flow", "npy"), path("valid", "npy"),
                path("confidence", "npy")};
    if (format == ResultFormat::Pfm)
        return {path("disp_0", "pfm"), path("disp_1", "pfm"), path("flow", "pfm"), path("confidence", "pfm")};
    return {path("disp_0", "pfm"), path("disp_1", "pfm"), path("flow", result_format_name(format))};
}

std::vector<std::string> write_results(const std::string &out_root, const std::string &id, const SceneFlowField &f,
                                       ResultFormat format) {
    require(!f.u.empty(), ErrorCode::InvalidArgument, "write_results: empty scene-flow field");
    const std::vector<std::string> paths = result_paths(out_root, id, format);
    const std::string &d0 = paths[0], &d1 = paths[1], &fl = paths[2];
    if (format == ResultFormat::Kitti) {
        write_disparity_png(d0, field_disparity0(f));
        write_disparity_png(d1, field_disparity1(f));
        write_flow_png(fl, field_flow(f));
        return paths;
    }
    const auto write_map = format == ResultFormat::Npy ? write_npy : write_pfm;
    write_map(d0, disparity_with_nan(field_disparity0(f)));
    write_map(d1, disparity_with_nan(field_disparity1(f)));
    if (format == ResultFormat::Flo) {
        write_flo(fl, field_flow(f));
    } else if (format == ResultFormat::Npy) {
        write_npy(fl, flow_with_nan(field_flow(f)));
        write_npy(paths[3], cv::Mat1b(f.valid != 0) / 255);
        write_npy(paths[4], confidence_map(f));
    } else {
        write_map(fl, flow_with_valid(field_flow(f)));
        write_pfm(paths[3], confidence_map(f));
    }
    return paths;
}

}  // namespace lidarflow::io
