// SPDX-License-Identifier: MIT
#include "convert.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/limits.hpp"
#include "core/maps.hpp"
#include "guard.hpp"
#include "lidar/projection.hpp"

namespace lidarflow::capi {
namespace {

constexpr size_t kLidarEntryBytes = 3 * sizeof(float);

int channels_of(int32_t format) {
    switch (format) {
    case LF_PIXEL_GRAY8: return 1;
    case LF_PIXEL_RGB8:
    case LF_PIXEL_BGR8: return 3;
    default: return 0;
    }
}

bool finite_all(const double *v, int n) {
    for (int i = 0; i < n; ++i)
        if (!std::isfinite(v[i])) return false;
    return true;
}

// Reads entry i as three floats; memcpy because the caller's stride need not keep alignment.
void read_entry(const lf_lidar_t &l, size_t stride, uint32_t i, float out[3]) {
    std::memcpy(out, static_cast<const unsigned char *>(l.data) + static_cast<size_t>(i) * stride, kLidarEntryBytes);
}

std::string entry_text(uint32_t i, const float e[3]) {
    return "lidar entry " + std::to_string(i) + " (" + std::to_string(e[0]) + ", " + std::to_string(e[1]) + ", " +
           std::to_string(e[2]) + ")";
}

SparseLidar from_disparities(const lf_lidar_t &l, size_t stride, cv::Size size) {
    // Larger disparity wins on a shared pixel (nearer surface), as in the projection.
    // An entry off the image is dropped and counted, as a projected 3-D point is: one point
    // must not cost the frame.
    DisparityMap map = filled(size, kInvalidDisparity);
    lidar::DroppedPoints dropped;
    dropped.seen = l.count;
    for (uint32_t i = 0; i < l.count; ++i) {
        float e[3];
        read_entry(l, stride, i, e);
        require(std::isfinite(e[0]) && std::isfinite(e[1]) && std::isfinite(e[2]), ErrorCode::InvalidArgument,
                entry_text(i, e) + " is not finite");
        require(e[2] >= 0.0f && e[2] <= kMaxLidarDisparity, ErrorCode::InvalidArgument,
                entry_text(i, e) + " has a disparity outside [0, " +
                    std::to_string(static_cast<int>(kMaxLidarDisparity)) + "] px");
        int x = 0, y = 0;
        if (!lidar::nearest_pixel(e[0], e[1], size, x, y)) {
            ++dropped.outside;
            continue;
        }
        float &cell = map(y, x);
        if (e[2] > cell) cell = e[2];
    }
    SparseLidar out = SparseLidar::from_map(map);
    lidar::report_dropped_points(dropped, 0.0, size, out.points.size());
    return out;
}

SparseLidar from_points(const lf_lidar_t &l, size_t stride, cv::Size size, const Calibration &cal) {
    const bool move = l.kind == LF_LIDAR_POINTS_LIDAR;
    require(!move || cal.has_lidar_to_camera, ErrorCode::InvalidArgument,
            "LF_LIDAR_POINTS_LIDAR needs the calibration's lidar_to_camera (has_lidar_to_camera = 0)");
    std::vector<cv::Point3f> points(l.count);
    for (uint32_t i = 0; i < l.count; ++i) {
        float e[3];
        read_entry(l, stride, i, e);
        require(std::isfinite(e[0]) && std::isfinite(e[1]) && std::isfinite(e[2]), ErrorCode::InvalidArgument,
                entry_text(i, e) + " is not finite");
        points[i] = {e[0], e[1], e[2]};
    }
    return lidar::project_to_left_camera(points, move ? &cal.lidar_to_camera : nullptr, cal.camera, size);
}

}  // namespace

namespace {

io::RawCamera raw_camera(const lf_raw_camera_t &c) {
    io::RawCamera r;
    std::copy(c.K, c.K + 9, r.K.val);
    std::copy(c.D, c.D + 8, r.D.val);
    std::copy(c.R, c.R + 9, r.R.val);
    std::copy(c.P, c.P + 12, r.P.val);
    return r;
}

lf_raw_camera_t raw_camera(const io::RawCamera &r) {
    lf_raw_camera_t c;
    std::copy(r.K.val, r.K.val + 9, c.K);
    std::copy(r.D.val, r.D.val + 8, c.D);
    std::copy(r.R.val, r.R.val + 9, c.R);
    std::copy(r.P.val, r.P.val + 12, c.P);
    return c;
}

bool same(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b)); }

// The fields after the first layout: image size and the raw rig, checked against the camera.
io::Rig convert_rig(const lf_calibration_t &c, const StereoCamera &camera) {
    const uint32_t side = static_cast<uint32_t>(kMaxImageSide);
    require(c.image_width <= side && c.image_height <= side && (c.image_width == 0) == (c.image_height == 0),
            ErrorCode::InvalidArgument,
            "calibration: image_width x image_height " + std::to_string(c.image_width) + "x" +
                std::to_string(c.image_height) + " is not 0x0 (unknown) or a size up to " +
                std::to_string(kMaxImageSide) + " px per side");
    require(c.rectify <= 1 && c.reserved == 0, ErrorCode::InvalidArgument,
            "calibration: rectify must be 0 or 1 and reserved 0");
    const cv::Size size(static_cast<int>(c.image_width), static_cast<int>(c.image_height));
    if (!c.rectify) return io::rig_from_pinhole(camera, size);
    io::Rig rig = io::rig_from_cameras(raw_camera(c.raw_left), raw_camera(c.raw_right), size, "calibration",
                                       ErrorCode::InvalidArgument);
    const StereoCamera &r = rig.rect.camera;
    require(same(camera.fx, r.fx) && same(camera.fy, r.fy) && same(camera.cx, r.cx) && same(camera.cy, r.cy) &&
                same(camera.baseline, r.baseline),
            ErrorCode::InvalidArgument,
            "calibration: fx, fy, cx, cy, baseline differ from the rectified camera of raw_left.P / raw_right.P");
    rig.rectify = true;
    return rig;
}

}  // namespace

void check_calibration_size(uint32_t struct_size, const char *what) {
    require(struct_size == LF_CALIBRATION_V1_SIZE || struct_size >= sizeof(lf_calibration_t),
            ErrorCode::InvalidArgument, [&] {
                return std::string(what) + ".struct_size is " + std::to_string(struct_size) + ", expected " +
                       std::to_string(sizeof(lf_calibration_t)) + " (lf_calibration_init) or " +
                       std::to_string(LF_CALIBRATION_V1_SIZE) + " (the first layout)";
            });
}

lf_calibration_t calibration_of_rig(const io::Rig &rig) {
    lf_calibration_t c;
    lf_calibration_init(&c);
    const StereoCamera &cam = rig.rect.camera;
    c.fx = cam.fx;
    c.fy = cam.fy;
    c.cx = cam.cx;
    c.cy = cam.cy;
    c.baseline = cam.baseline;
    c.image_width = static_cast<uint32_t>(rig.rect.image_size.width);
    c.image_height = static_cast<uint32_t>(rig.rect.image_size.height);
    if (rig.rectify) {
        c.rectify = 1;
        c.raw_left = raw_camera(rig.left);
        c.raw_right = raw_camera(rig.right);
    }
    return c;
}

Calibration convert_calibration(const lf_calibration_t &given) {
    check_calibration_size(given.struct_size, "calibration");
    if (given.struct_size > sizeof(lf_calibration_t))
        check_struct_size(&given, given.struct_size, sizeof(lf_calibration_t), "calibration");
    // The first layout's caller owns only its first bytes: the later fields read as zero.
    lf_calibration_t c;
    std::memset(&c, 0, sizeof c);
    std::memcpy(&c, &given, std::min<size_t>(given.struct_size, sizeof c));
    Calibration out;
    out.camera = {c.fx, c.fy, c.cx, c.cy, c.baseline};
    const std::string range = camera_range_error(out.camera);
    require(range.empty(), ErrorCode::InvalidArgument, "calibration: " + range);
    out.rig = convert_rig(c, out.camera);
    require(c.has_lidar_to_camera <= 1, ErrorCode::InvalidArgument, "calibration: has_lidar_to_camera must be 0 or 1");
    out.has_lidar_to_camera = c.has_lidar_to_camera == 1;
    if (out.has_lidar_to_camera) {
        require(finite_all(c.lidar_to_camera, 16), ErrorCode::InvalidArgument,
                "calibration: lidar_to_camera must be finite");
        const double *r = c.lidar_to_camera + 12;
        require(r[0] == 0 && r[1] == 0 && r[2] == 0 && r[3] == 1, ErrorCode::InvalidArgument,
                "calibration: the last row of lidar_to_camera must be 0 0 0 1");
        for (int i = 0; i < 16; ++i) out.lidar_to_camera.val[i] = c.lidar_to_camera[i];
        // A rigid transform, as the KITTI reader checks it: a scaled one (mm for m) moves every
        // point off its pixel.
        const cv::Matx33d R = out.lidar_to_camera.get_minor<3, 3>(0, 0);
        require(cv::norm(R.t() * R - cv::Matx33d::eye(), cv::NORM_INF) <= 1e-3 && cv::determinant(R) > 0,
                ErrorCode::InvalidArgument, "calibration: the rotation of lidar_to_camera is not a rotation matrix");
        for (int i = 0; i < 3; ++i)
            require(std::abs(out.lidar_to_camera(i, 3)) <= kMaxRigTranslation, ErrorCode::InvalidArgument,
                    "calibration: the translation of lidar_to_camera exceeds 1000 m");
    }
    return out;
}

cv::Mat convert_image(const lf_image_t &image, const char *what) {
    const std::string name(what);
    require(image.data != nullptr, ErrorCode::InvalidArgument, name + ".data is NULL");
    require(image.width > 0 && image.height > 0, ErrorCode::InvalidArgument,
            name + " is " + std::to_string(image.width) + "x" + std::to_string(image.height) + ": empty");
    constexpr auto max_side = static_cast<uint32_t>(kMaxImageSide);
    require(image.width <= max_side && image.height <= max_side, ErrorCode::InvalidArgument,
            name + " is " + std::to_string(image.width) + "x" + std::to_string(image.height) + ", larger than " +
                std::to_string(kMaxImageSide) + " px per side");
    const int channels = channels_of(image.format);
    require(channels > 0, ErrorCode::InvalidArgument,
            name + ".format " + std::to_string(image.format) + " is not LF_PIXEL_GRAY8, RGB8 or BGR8");
    const uint64_t row_bytes = static_cast<uint64_t>(image.width) * channels;
    require(image.stride_bytes >= row_bytes, ErrorCode::SizeMismatch,
            name + ".stride_bytes " + std::to_string(image.stride_bytes) + " is smaller than a row (" +
                std::to_string(row_bytes) + " bytes)");
    const int w = static_cast<int>(image.width), h = static_cast<int>(image.height);
    cv::Mat out(h, w, channels == 1 ? CV_8UC1 : CV_8UC3);
    const unsigned char *src = static_cast<const unsigned char *>(image.data);
    for (int y = 0; y < h; ++y) std::memcpy(out.ptr(y), src + static_cast<uint64_t>(y) * image.stride_bytes, row_bytes);
    if (image.format == LF_PIXEL_RGB8) cv::cvtColor(out, out, cv::COLOR_RGB2BGR);
    return out;
}

SparseLidar convert_lidar(const lf_lidar_t *lidar, cv::Size size, const Calibration &calibration) {
    if (!lidar || lidar->kind == LF_LIDAR_NONE) return SparseLidar{size.width, size.height, {}};
    const lf_lidar_t &l = *lidar;
    require(l.kind == LF_LIDAR_POINTS_CAMERA || l.kind == LF_LIDAR_POINTS_LIDAR || l.kind == LF_LIDAR_DISPARITY,
            ErrorCode::InvalidArgument, "lidar.kind " + std::to_string(l.kind) + " is not an lf_lidar_kind_t");
    require(l.count == 0 || l.data != nullptr, ErrorCode::InvalidArgument,
            "lidar.data is NULL with count " + std::to_string(l.count));
    const size_t stride = l.stride_bytes == 0 ? kLidarEntryBytes : static_cast<size_t>(l.stride_bytes);
    require(stride >= kLidarEntryBytes, ErrorCode::SizeMismatch,
            "lidar.stride_bytes " + std::to_string(l.stride_bytes) + " is smaller than an entry (12 bytes)");
    if (l.kind == LF_LIDAR_DISPARITY) return from_disparities(l, stride, size);
    return from_points(l, stride, size, calibration);
}

}  // namespace lidarflow::capi
