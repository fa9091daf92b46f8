// SPDX-License-Identifier: MIT
#include "io/rig.hpp"

#include <sys/stat.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "core/size_text.hpp"
#include "io/storage_text.hpp"

namespace lidarflow::io {
namespace {

// A regular file of at most kMaxCalibrationFileBytes: a FIFO would block the reader, a huge file
// exhaust memory, before anything could be said about them.
std::string read_calibration_text(const std::string &path) {
    struct stat st {};
    require(::stat(path.c_str(), &st) == 0, ErrorCode::Io, "cannot open " + path);
    require(S_ISREG(st.st_mode), ErrorCode::Io, path + " is not a regular file");
    require(static_cast<uint64_t>(st.st_size) <= kMaxCalibrationFileBytes, ErrorCode::Io,
            path + " is " + std::to_string(st.st_size) + " bytes, more than a calibration file (" +
                std::to_string(kMaxCalibrationFileBytes) + " bytes at most)");
    std::ifstream in(path, std::ios::binary);
    require(in.good(), ErrorCode::Io, "cannot open " + path);
    std::string text;
    text.reserve(static_cast<size_t>(st.st_size));
    char buf[4096];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
        text.append(buf, static_cast<size_t>(in.gcount()));
        require(text.size() <= kMaxCalibrationFileBytes, ErrorCode::Io, path + " grew past a calibration file's size");
    }
    require(!in.bad(), ErrorCode::Io, "cannot read " + path);
    return text;
}

bool starts_with(const std::string &s, const char *prefix) { return s.rfind(prefix, 0) == 0; }

std::string skip_space(const std::string &text) {
    const size_t b = text.find_first_not_of(" \t\r\n");
    return b == std::string::npos ? std::string() : text.substr(b);
}

// OpenCV's YAML parser needs the "%YAML:1.0" line that ROS camera_info files and hand-written
// files lack.
cv::FileStorage open_storage(const std::string &text, const std::string &source) {
    const std::string body = skip_space(text);
    const bool tagged = starts_with(body, "%YAML") || starts_with(body, "<?xml") || starts_with(body, "<opencv_storage");
    const std::string input = tagged ? body : "%YAML:1.0\n---\n" + body;
    require(input.find('\0') == std::string::npos, ErrorCode::Format, source + ": a NUL byte in a text file");
    require(!xml_cut_short(body, body), ErrorCode::Format,
            source + ": the XML ends before its last tag is closed (a truncated file?)");
    try {
        cv::FileStorage fs(input, cv::FileStorage::READ | cv::FileStorage::MEMORY);
        require(fs.isOpened(), ErrorCode::Format, source + ": not a YAML or XML file OpenCV can read");
        // fs[key] asserts on a top level that is a sequence or a scalar.
        require(fs.root().isMap(), ErrorCode::Format, source + ": the top level is not a map of keys");
        return fs;
    } catch (const cv::Exception &e) {
        throw Error(ErrorCode::Format, source + ": not a YAML or XML file OpenCV can read (" + e.err + ")");
    } catch (const std::length_error &) {
        // OpenCV 4.6's parser lets some malformed input size a string from garbage.
        throw Error(ErrorCode::Format, source + ": not a YAML or XML file OpenCV can read");
    }
}

double number(const cv::FileNode &n, const std::string &what, const std::string &source) {
    require(n.isInt() || n.isReal(), ErrorCode::Format, source + ": " + what + " is not a number");
    const double v = n.real();
    require(std::isfinite(v), ErrorCode::Format, source + ": " + what + " is not finite");
    return v;
}

// The numbers of a matrix node: an opencv-matrix or ROS map (rows, cols, data) or a plain
// sequence. Empty when the key is absent. At most `max_values` are read.
std::vector<double> values(const cv::FileNode &node, const std::string &key, size_t max_values,
                           const std::string &source) {
    if (node.empty() || node.isNone()) return {};
    cv::FileNode data = node;
    if (node.isMap()) {
        data = node["data"];
        require(data.isSeq(), ErrorCode::Format, source + ": " + key + " has no data sequence");
        const cv::FileNode rows = node["rows"], cols = node["cols"];
        if (!rows.empty() || !cols.empty()) {
            require(rows.isInt() && cols.isInt() && static_cast<int>(rows) >= 0 && static_cast<int>(cols) >= 0 &&
                        static_cast<size_t>(static_cast<int>(rows)) * static_cast<size_t>(static_cast<int>(cols)) ==
                            data.size(),
                    ErrorCode::Format, source + ": " + key + ": rows x cols does not match its data");
        }
    }
    require(data.isSeq(), ErrorCode::Format, source + ": " + key + " is not a matrix");
    require(data.size() <= max_values, ErrorCode::Format,
            source + ": " + key + " has " + std::to_string(data.size()) + " values, at most " +
                std::to_string(max_values) + " expected");
    std::vector<double> out;
    for (size_t i = 0; i < data.size(); ++i)
        out.push_back(number(data[static_cast<int>(i)], key + "[" + std::to_string(i) + "]", source));
    return out;
}

template <int R, int C>
bool read_matrix(const cv::FileStorage &fs, const std::vector<std::string> &keys, cv::Matx<double, R, C> &out,
                 const std::string &source) {
    for (const std::string &key : keys) {
        const std::vector<double> v = values(fs[key], key, R * C, source);
        if (v.empty()) continue;
        require(v.size() == static_cast<size_t>(R * C), ErrorCode::Format,
                source + ": " + key + " has " + std::to_string(v.size()) + " values, expected " +
                    std::to_string(R) + "x" + std::to_string(C));
        for (int i = 0; i < R * C; ++i) out.val[i] = v[static_cast<size_t>(i)];
        return true;
    }
    return false;
}

template <int R, int C>
cv::Matx<double, R, C> required_matrix(const cv::FileStorage &fs, const std::vector<std::string> &keys,
                                       const std::string &source) {
    cv::Matx<double, R, C> m;
    std::string names = keys.front();
    for (size_t i = 1; i < keys.size(); ++i) names += " or " + keys[i];
    require(read_matrix(fs, keys, m, source), ErrorCode::Format, source + ": missing key " + names);
    return m;
}

// OpenCV's and ROS's distortion vectors: 0, 4, 5, 8, 12 or 14 coefficients; the thin-prism and
// tilt terms beyond the eighth are not supported unless zero.
cv::Vec<double, 8> distortion(const cv::FileStorage &fs, const std::string &key, const std::string &source) {
    const std::vector<double> v = values(fs[key], key, 14, source);
    const size_t n = v.size();
    require(n == 0 || n == 4 || n == 5 || n == 8 || n == 12 || n == 14, ErrorCode::Format,
            source + ": " + key + " has " + std::to_string(n) + " coefficients (0, 4, 5, 8, 12 or 14 expected)");
    cv::Vec<double, 8> d = cv::Vec<double, 8>::all(0);
    for (size_t i = 0; i < n; ++i) {
        if (i < 8)
            d[static_cast<int>(i)] = v[i];
        else
            require(v[i] == 0, ErrorCode::Format,
                    source + ": " + key + ": thin-prism / tilt coefficients (beyond the eighth) are not supported");
    }
    return d;
}

int whole_side(double v, const std::string &what, const std::string &source) {
    require(v >= 0 && v <= kMaxImageSide && v == std::floor(v), ErrorCode::Format,
            source + ": " + what + " is not an image side (whole pixels, 0 to " + std::to_string(kMaxImageSide) + ")");
    return static_cast<int>(v);
}

// image_width + image_height, or imageSize / image_size = [w, h]; 0x0 when absent.
cv::Size image_size(const cv::FileStorage &fs, const std::string &source) {
    const cv::FileNode w = fs["image_width"], h = fs["image_height"];
    int width = 0, height = 0;
    if (!w.empty() || !h.empty()) {
        require(!w.empty() && !h.empty(), ErrorCode::Format, source + ": image_width and image_height come together");
        width = whole_side(number(w, "image_width", source), "image_width", source);
        height = whole_side(number(h, "image_height", source), "image_height", source);
    } else {
        for (const char *key : {"imageSize", "image_size"}) {
            const std::vector<double> v = values(fs[key], key, 2, source);
            if (v.empty()) continue;
            require(v.size() == 2, ErrorCode::Format, source + ": " + key + " is not [width, height]");
            width = whole_side(v[0], key, source);
            height = whole_side(v[1], key, source);
            break;
        }
    }
    require((width == 0) == (height == 0), ErrorCode::Format, source + ": image size has one side 0");
    return {width, height};
}

bool near(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::max(std::abs(a), std::abs(b))); }

template <int R, int C>
bool near(const cv::Matx<double, R, C> &a, const cv::Matx<double, R, C> &b) {
    for (int i = 0; i < R * C; ++i)
        if (!near(a.val[i], b.val[i])) return false;
    return true;
}

template <int R, int C>
bool finite(const cv::Matx<double, R, C> &m) {
    for (double v : m.val)
        if (!std::isfinite(v)) return false;
    return true;
}

cv::Matx33d left3x3(const cv::Matx34d &P) { return P.get_minor<3, 3>(0, 0); }

void check_camera(const RawCamera &c, const std::string &side, const std::string &source, ErrorCode code) {
    const std::string where = source + ": " + side + " camera: ";
    require(finite(c.K) && finite(c.R) && finite(c.P), code, where + "non-finite entries");
    for (double d : c.D.val) require(std::isfinite(d), code, where + "non-finite distortion");
    require(c.K(0, 0) > 0 && c.K(1, 1) > 0 && c.K(1, 0) == 0 && c.K(2, 0) == 0 && c.K(2, 1) == 0 && c.K(2, 2) == 1,
            code, where + "K is not a pinhole matrix [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0");
    require(cv::norm(c.R.t() * c.R - cv::Matx33d::eye(), cv::NORM_INF) <= 1e-3 && cv::determinant(c.R) > 0, code,
            where + "the rectification matrix is not a rotation");
    require(c.P(0, 0) > 0 && c.P(1, 1) > 0 && c.P(1, 0) == 0 && c.P(2, 0) == 0 && c.P(2, 1) == 0 && c.P(2, 2) == 1 &&
                c.P(2, 3) == 0,
            code, where + "P is not a rectified projection [fx 0 cx Tx; 0 fy cy Ty; 0 0 1 0]");
}

bool is_identity_rig_camera(const RawCamera &c) {
    return c.D == cv::Vec<double, 8>::all(0) && near(c.R, cv::Matx33d::eye()) && near(c.K, left3x3(c.P));
}

}  // namespace

Rig rig_from_cameras(const RawCamera &left, const RawCamera &right, cv::Size size, const std::string &source,
                     ErrorCode code) {
    check_camera(left, "left", source, code);
    check_camera(right, "right", source, code);
    require(near(left3x3(left.P), left3x3(right.P)), code,
            source + ": the left and right projections have different intrinsics (not one rectified pair)");
    require(near(left.P(1, 3), right.P(1, 3)), code,
            source + ": the cameras are offset vertically in the rectified frame (a vertical rig is not supported)");
    require(size.width >= 0 && size.height >= 0 && size.width <= kMaxImageSide && size.height <= kMaxImageSide &&
                (size.width == 0) == (size.height == 0),
            code, source + ": image size out of range");
    Rig rig;
    rig.left = left;
    rig.right = right;
    rig.rect.P_rect_02 = left.P;
    rig.rect.P_rect_03 = right.P;
    rig.rect.R_rect_00 = left.R;
    rig.rect.image_size = size;
    StereoCamera &cam = rig.rect.camera;
    cam.fx = left.P(0, 0);
    cam.fy = left.P(1, 1);
    cam.cx = left.P(0, 2);
    cam.cy = left.P(1, 2);
    cam.baseline = (left.P(0, 3) - right.P(0, 3)) / cam.fx;
    require(cam.baseline > 0, code,
            source + ": the projections give a non-positive baseline (right camera not right of left)");
    const std::string range = camera_range_error(cam);
    require(range.empty(), code, source + ": the projections give " + range);
    rig.rectify = !is_identity_rig_camera(left) || !is_identity_rig_camera(right);
    return rig;
}

Rig rig_from_kitti(const CamToCamCalib &calib) {
    // parse_calib_cam_to_cam checked it; KITTI's P carry camera offsets in y and z too, which
    // the camera_info form (rig_from_cameras) does not allow.
    const std::string range = camera_range_error(calib.camera);
    require(range.empty(), ErrorCode::InvalidArgument, "KITTI calibration: " + range);
    Rig rig;
    rig.rect = calib;
    rig.left.P = calib.P_rect_02;
    rig.right.P = calib.P_rect_03;
    rig.left.K = left3x3(calib.P_rect_02);
    rig.right.K = left3x3(calib.P_rect_03);
    return rig;
}

Rig rig_from_pinhole(const StereoCamera &camera, cv::Size image_size) {
    const std::string range = camera_range_error(camera);
    require(range.empty(), ErrorCode::InvalidArgument, "camera: " + range);
    CamToCamCalib c = calib_from_camera(camera);
    c.image_size = image_size;
    return rig_from_kitti(c);
}

Rig parse_opencv_stereo(const std::string &text, const std::string &source) {
    const cv::FileStorage fs = open_storage(text, source);
    RawCamera left, right;
    left.K = required_matrix<3, 3>(fs, {"M1", "K1"}, source);
    right.K = required_matrix<3, 3>(fs, {"M2", "K2"}, source);
    left.D = distortion(fs, "D1", source);
    right.D = distortion(fs, "D2", source);
    const cv::Size size = image_size(fs, source);
    cv::Matx33d R1, R2;
    cv::Matx34d P1, P2;
    const int given = int(read_matrix(fs, {"R1"}, R1, source)) + int(read_matrix(fs, {"R2"}, R2, source)) +
                      int(read_matrix(fs, {"P1"}, P1, source)) + int(read_matrix(fs, {"P2"}, P2, source));
    require(given == 0 || given == 4, ErrorCode::Format, source + ": R1 R2 P1 P2 come together (some are missing)");
    if (given == 4) {
        left.R = R1;
        right.R = R2;
        left.P = P1;
        right.P = P2;
        return rig_from_cameras(left, right, size, source);
    }
    const cv::Matx33d R = required_matrix<3, 3>(fs, {"R"}, source);
    const cv::Matx31d T = required_matrix<3, 1>(fs, {"T"}, source);
    require(finite(R) && finite(T), ErrorCode::Format, source + ": non-finite R or T");
    require(cv::norm(R.t() * R - cv::Matx33d::eye(), cv::NORM_INF) <= 1e-3 && cv::determinant(R) > 0,
            ErrorCode::Format, source + ": R is not a rotation matrix");
    const bool no_distortion = left.D == cv::Vec<double, 8>::all(0) && right.D == cv::Vec<double, 8>::all(0);
    if (no_distortion && near(R, cv::Matx33d::eye()) && near(left.K, right.K) && T(1) == 0 && T(2) == 0) {
        // Already rectified: stereoRectify would still re-centre and rescale the images.
        for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 3; ++k) left.P(r, k) = right.P(r, k) = left.K(r, k);
        right.P(0, 3) = left.K(0, 0) * T(0);
        right.K = left.K;
        return rig_from_cameras(left, right, size, source);
    }
    require(!size.empty(), ErrorCode::Format,
            source + ": the rig is not rectified and has no R1 R2 P1 P2: rectifying needs the image size "
                     "(image_width and image_height)");
    for (const RawCamera *c : {&left, &right})
        require(finite(c->K) && c->K(0, 0) > 0 && c->K(1, 1) > 0, ErrorCode::Format,
                source + ": M1 / M2 are not pinhole matrices");
    cv::Mat r1, r2, p1, p2, q;
    try {
        cv::stereoRectify(cv::Mat(left.K), cv::Mat(left.D), cv::Mat(right.K), cv::Mat(right.D), size, cv::Mat(R),
                          cv::Mat(T), r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0);
    } catch (const cv::Exception &e) {
        throw Error(ErrorCode::Format, source + ": cv::stereoRectify failed on this rig (" + e.err + ")");
    }
    left.R = cv::Matx33d(r1);
    right.R = cv::Matx33d(r2);
    left.P = cv::Matx34d(p1);
    right.P = cv::Matx34d(p2);
    return rig_from_cameras(left, right, size, source);
}

namespace {

RawCamera camera_info(const cv::FileStorage &fs, const std::string &source, cv::Size &size) {
    const cv::FileNode model = fs["distortion_model"];
    if (!model.empty()) {
        require(model.isString(), ErrorCode::Format, source + ": distortion_model is not a name");
        const std::string m = model.string();
        require(m.empty() || m == "plumb_bob" || m == "rational_polynomial", ErrorCode::Format,
                source + ": distortion_model '" + m + "' is not supported (plumb_bob or rational_polynomial)");
    }
    RawCamera c;
    c.K = required_matrix<3, 3>(fs, {"camera_matrix"}, source);
    c.D = distortion(fs, "distortion_coefficients", source);
    c.R = required_matrix<3, 3>(fs, {"rectification_matrix"}, source);
    c.P = required_matrix<3, 4>(fs, {"projection_matrix"}, source);
    size = image_size(fs, source);
    return c;
}

}  // namespace

Rig parse_camera_info_pair(const std::string &left_text, const std::string &left_source, const std::string &right_text,
                           const std::string &right_source) {
    cv::Size left_size, right_size;
    const RawCamera left = camera_info(open_storage(left_text, left_source), left_source, left_size);
    const RawCamera right = camera_info(open_storage(right_text, right_source), right_source, right_size);
    require(left_size == right_size, ErrorCode::Format,
            left_source + " and " + right_source + " give different image sizes");
    return rig_from_cameras(left, right, left_size, left_source + "," + right_source);
}

Rig read_rig(const std::string &spec) {
    require(!spec.empty(), ErrorCode::InvalidArgument, "no calibration file given");
    struct stat st {};
    const size_t comma = spec.find(',');
    if (comma != std::string::npos && ::stat(spec.c_str(), &st) != 0) {
        const std::string left = spec.substr(0, comma), right = spec.substr(comma + 1);
        require(!left.empty() && !right.empty() && right.find(',') == std::string::npos, ErrorCode::InvalidArgument,
                "calibration '" + spec + "': expected FILE or LEFT,RIGHT (two camera_info files)");
        const std::string left_text = read_calibration_text(left);  // left first: errors in reading order
        return parse_camera_info_pair(left_text, left, read_calibration_text(right), right);
    }
    const std::string text = read_calibration_text(spec);
    const std::string body = skip_space(text);
    const bool kitti = body.find("P_rect_02:") != std::string::npos;
    if (kitti && !starts_with(body, "%YAML") && !starts_with(body, "<")) return rig_from_kitti(parse_calib_cam_to_cam(text, spec));
    require(body.find("camera_matrix") == std::string::npos || body.find("M1") != std::string::npos ||
                body.find("K1") != std::string::npos,
            ErrorCode::Format,
            spec + ": a camera_info file describes one camera: give both, --calib LEFT.yaml,RIGHT.yaml");
    require(starts_with(body, "%YAML") || starts_with(body, "<") || body.find("M1") != std::string::npos ||
                body.find("K1") != std::string::npos,
            ErrorCode::Format,
            spec + ": not a KITTI calib_cam_to_cam file (P_rect_02:), an OpenCV stereo calibration (M1 D1 M2 D2 R T) "
                   "or a camera_info pair");
    return parse_opencv_stereo(text, spec);
}

std::string image_size_mismatch(cv::Size calibration, cv::Size input) {
    if (calibration.empty() || calibration == input) return "";
    return "the images are " + size_text(input) + " but the calibration is for " + size_text(calibration);
}

}  // namespace lidarflow::io
