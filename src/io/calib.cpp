// SPDX-License-Identifier: MIT
#include "io/calib.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "io/read_file.hpp"

namespace lidarflow::io {
namespace {

std::string trim(const std::string &s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) return "";
    const auto e = s.find_last_not_of(" \t\r");
    return s.substr(b, e - b + 1);
}

// Collects the value text of the wanted keys only: other keys (calib_time, corner_dist, ...)
// carry non-numeric values that must not make a valid file fail.
std::map<std::string, std::string> collect(const std::string &text, const std::string &source,
                                           const std::vector<std::string> &wanted,
                                           const std::vector<std::string> &optional = {}) {
    std::map<std::string, std::string> found;
    std::istringstream in(text);
    std::string line;
    int lineno = 0;
    while (std::getline(in, line)) {
        ++lineno;
        const std::string t = trim(line);
        if (t.empty()) continue;
        const auto colon = t.find(':');
        require(colon != std::string::npos && colon > 0, ErrorCode::Format,
                source + ":" + std::to_string(lineno) + ": expected 'KEY: values'");
        const std::string key = trim(t.substr(0, colon));
        bool is_wanted = false;
        for (const auto &w : wanted) is_wanted = is_wanted || w == key;
        for (const auto &w : optional) is_wanted = is_wanted || w == key;
        if (!is_wanted) continue;
        require(found.count(key) == 0, ErrorCode::Format,
                source + ":" + std::to_string(lineno) + ": duplicate key " + key);
        found[key] = t.substr(colon + 1);
    }
    for (const auto &w : wanted)
        require(found.count(w) == 1, ErrorCode::Format, source + ": missing key " + w);
    return found;
}

std::vector<double> numbers(const std::string &values, size_t expected, const std::string &key,
                            const std::string &source) {
    std::istringstream in(values);
    std::vector<double> out;
    std::string tok;
    while (in >> tok) {
        errno = 0;
        char *end = nullptr;
        const double v = std::strtod(tok.c_str(), &end);
        require(*end == '\0' && errno != ERANGE, ErrorCode::Format,
                source + ": " + key + ": '" + tok + "' is not a number");
        require(std::isfinite(v), ErrorCode::Format, source + ": " + key + ": non-finite value '" + tok + "'");
        out.push_back(v);
    }
    require(out.size() == expected, ErrorCode::Format,
            source + ": " + key + ": expected " + std::to_string(expected) + " values, got " +
                std::to_string(out.size()));
    return out;
}

template <int R, int C>
cv::Matx<double, R, C> matrix(const std::map<std::string, std::string> &found, const std::string &key,
                              const std::string &source) {
    const std::vector<double> v = numbers(found.at(key), R * C, key, source);
    cv::Matx<double, R, C> m;
    for (int i = 0; i < R * C; ++i) m.val[i] = v[i];
    return m;
}

// Calibration files are a few kilobytes; a bound keeps /dev/zero or a huge file from being read.
constexpr uint64_t kMaxCalibrationBytes = uint64_t{1} << 20;

// A rotation as the C ABI checks lidar_to_camera: orthonormal within 1e-3 and det > 0 (a scaled
// or all-zero matrix moves every point off its pixel or out of the image).
void require_rotation(const cv::Matx33d &R, const std::string &key, const std::string &source) {
    const double ortho = cv::norm(R.t() * R - cv::Matx33d::eye(), cv::NORM_INF);
    require(ortho <= 1e-3 && cv::determinant(R) > 0, ErrorCode::Format, source + ": " + key + " is not a rotation matrix");
}

// A rectified camera's projection K [I | t]: the lower-left of K zero and its last row 0 0 1, the
// form velo_to_left_rect inverts.
void require_pinhole(const cv::Matx34d &P, const std::string &key, const std::string &source) {
    require(P(1, 0) == 0 && P(2, 0) == 0 && P(2, 1) == 0 && P(2, 2) == 1, ErrorCode::Format,
            source + ": " + key + " is not a rectified pinhole projection K [I | t] (rows 2 and 3 must start 0 fy cy, 0 0 1)");
}

template <int R, int C>
bool all_finite(const cv::Matx<double, R, C> &m) {
    for (int i = 0; i < R * C; ++i)
        if (!std::isfinite(m.val[i])) return false;
    return true;
}

template <int R, int C>
void write_matrix(std::FILE *f, const char *key, const cv::Matx<double, R, C> &m) {
    std::fprintf(f, "%s:", key);
    // 17 significant digits make the text round-trip to the same doubles.
    for (int i = 0; i < R * C; ++i) std::fprintf(f, " %.16e", m.val[i]);
    std::fprintf(f, "\n");
}

}  // namespace

CamToCamCalib parse_calib_cam_to_cam(const std::string &text, const std::string &source) {
    const auto found = collect(text, source, {"P_rect_02", "P_rect_03", "R_rect_00"}, {"S_rect_02"});
    CamToCamCalib c;
    if (found.count("S_rect_02")) {
        // KITTI writes the size as doubles ("1.242000e+03 3.750000e+02").
        const cv::Matx12d s = matrix<1, 2>(found, "S_rect_02", source);
        require(s(0) >= 1 && s(1) >= 1 && s(0) <= kMaxImageSide && s(1) <= kMaxImageSide && s(0) == std::floor(s(0)) &&
                    s(1) == std::floor(s(1)),
                ErrorCode::Format, source + ": S_rect_02 is not an image size (whole pixels, 1 to " +
                                       std::to_string(kMaxImageSide) + " per side)");
        c.image_size = {static_cast<int>(s(0)), static_cast<int>(s(1))};
    }
    c.P_rect_02 = matrix<3, 4>(found, "P_rect_02", source);
    c.P_rect_03 = matrix<3, 4>(found, "P_rect_03", source);
    c.R_rect_00 = matrix<3, 3>(found, "R_rect_00", source);
    require_pinhole(c.P_rect_02, "P_rect_02", source);
    require_pinhole(c.P_rect_03, "P_rect_03", source);
    require_rotation(c.R_rect_00, "R_rect_00", source);
    const cv::Matx34d &P2 = c.P_rect_02, &P3 = c.P_rect_03;
    c.camera.fx = P2(0, 0);
    c.camera.fy = P2(1, 1);
    c.camera.cx = P2(0, 2);
    c.camera.cy = P2(1, 2);
    require(c.camera.fx > 0 && c.camera.fy > 0, ErrorCode::Format,
            source + ": P_rect_02 has a non-positive focal length");
    c.camera.baseline = (P2(0, 3) - P3(0, 3)) / c.camera.fx;
    require(c.camera.baseline > 0, ErrorCode::Format,
            source + ": P_rect_02 / P_rect_03 give a non-positive baseline (right camera not right of left)");
    // Finite entries can still give an infinite baseline (1e308 - -1e308) or one no depth
    // computation survives.
    const std::string range = camera_range_error(c.camera);
    require(range.empty(), ErrorCode::Format, source + ": P_rect_02 / P_rect_03 give " + range);
    return c;
}

CamToCamCalib read_calib_cam_to_cam(const std::string &path) {
    return parse_calib_cam_to_cam(read_file(path, kMaxCalibrationBytes), path);
}

cv::Matx44d parse_calib_velo_to_cam(const std::string &text, const std::string &source) {
    const auto found = collect(text, source, {"R", "T"});
    const cv::Matx33d R = matrix<3, 3>(found, "R", source);
    const cv::Matx31d T = matrix<3, 1>(found, "T", source);
    require_rotation(R, "R", source);
    for (int i = 0; i < 3; ++i)
        require(std::fabs(T(i, 0)) <= kMaxRigTranslation, ErrorCode::Format,
                source + ": T moves the LiDAR more than " + std::to_string(static_cast<int>(kMaxRigTranslation)) +
                    " m from the camera");
    cv::Matx44d M = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) M(r, k) = R(r, k);
        M(r, 3) = T(r, 0);
    }
    return M;
}

cv::Matx44d read_calib_velo_to_cam(const std::string &path) {
    return parse_calib_velo_to_cam(read_file(path, kMaxCalibrationBytes), path);
}

void write_calib_cam_to_cam(const std::string &path, const CamToCamCalib &calib) {
    require(all_finite(calib.P_rect_02) && all_finite(calib.P_rect_03) && all_finite(calib.R_rect_00),
            ErrorCode::InvalidArgument, "non-finite calibration entry for " + path);
    const auto parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    require(!ec, ErrorCode::Io, "cannot create folder " + parent.string() + ": " + ec.message());
    std::FILE *f = std::fopen(path.c_str(), "w");
    require(f != nullptr, ErrorCode::Io, "cannot write " + path);
    write_matrix(f, "R_rect_00", calib.R_rect_00);
    write_matrix(f, "P_rect_02", calib.P_rect_02);
    write_matrix(f, "P_rect_03", calib.P_rect_03);
    if (!calib.image_size.empty())
        std::fprintf(f, "S_rect_02: %d %d\n", calib.image_size.width, calib.image_size.height);
    const bool ok = !std::ferror(f);
    require(std::fclose(f) == 0 && ok, ErrorCode::Io, "cannot write " + path);
}

CamToCamCalib calib_from_camera(const StereoCamera &camera) {
    const std::string range = camera_range_error(camera);
    require(range.empty(), ErrorCode::InvalidArgument, "calib_from_camera: " + range);
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    CamToCamCalib c;
    c.R_rect_00 = cv::Matx33d::eye();
    c.P_rect_02 = cv::Matx34d::zeros();
    c.P_rect_03 = cv::Matx34d::zeros();
    for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) c.P_rect_02(r, k) = c.P_rect_03(r, k) = K(r, k);
    c.P_rect_03(0, 3) = -camera.fx * camera.baseline;
    c.camera = camera;
    return c;
}

}  // namespace lidarflow::io
