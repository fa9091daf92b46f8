// SPDX-License-Identifier: MIT
#include "io/point_cloud.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/points3d.hpp"
#include "io/read_file.hpp"

namespace lidarflow::io {
namespace {

constexpr size_t kRecordBytes = 6 * 4 + 3;  // x y z dx dy dz float32, red green blue uchar
constexpr size_t kObjectMotionBytes = 3 * 4;  // omx omy omz float32

const std::string kHeaderProperties =
    "property float x\nproperty float y\nproperty float z\n"
    "property float dx\nproperty float dy\nproperty float dz\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\n";
const std::string kObjectMotionProperties = "property float omx\nproperty float omy\nproperty float omz\n";

void put_le32(std::string &buf, float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int k = 0; k < 4; ++k) buf.push_back(static_cast<char>((u >> (8 * k)) & 0xffu));
}

float get_le32(const char *p) {
    uint32_t u = 0;
    for (int k = 0; k < 4; ++k) u |= static_cast<uint32_t>(static_cast<unsigned char>(p[k])) << (8 * k);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

}  // namespace

std::vector<CloudPoint> scene_points(const SceneFlowField &f, const StereoCamera &camera, const cv::Mat &left0,
                                     const cv::Matx44d *ego) {
    double R[9] = {}, t[3] = {};
    if (ego)
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) R[3 * i + j] = (*ego)(i, j);
            t[i] = (*ego)(i, 3);
        }
    require(camera.valid(), ErrorCode::InvalidArgument, "scene_points: the camera calibration is not valid");
    require(!f.u.empty(), ErrorCode::InvalidArgument, "scene_points: empty scene-flow field");
    require(!left0.empty() && left0.depth() == CV_8U && (left0.channels() == 1 || left0.channels() == 3),
            ErrorCode::InvalidArgument, "scene_points: the colour image must be 8-bit grey or BGR");
    require(left0.size() == f.u.size(), ErrorCode::SizeMismatch, "scene_points: image and field differ in size");
    std::vector<CloudPoint> out;
    for (int y = 0; y < f.u.rows; ++y)
        for (int x = 0; x < f.u.cols; ++x) {
            ScenePoint3 p;
            if (!f.valid(y, x) ||
                !triangulate_scene_flow(camera, x, y, f.u(y, x), f.v(y, x), f.d0(y, x), f.d1(y, x), &p))
                continue;
            cv::Vec3b rgb;
            if (left0.channels() == 3) {
                const cv::Vec3b bgr = left0.at<cv::Vec3b>(y, x);
                rgb = {bgr[2], bgr[1], bgr[0]};
            } else {
                const uchar g = left0.at<uchar>(y, x);
                rgb = {g, g, g};
            }
            const cv::Vec3f pos(static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z));
            const cv::Vec3f mot(static_cast<float>(p.dx), static_cast<float>(p.dy), static_cast<float>(p.dz));
            // A non-finite u or v would give a non-finite motion: such a pixel is no point.
            if (!cv::checkRange(pos) || !cv::checkRange(mot)) continue;
            CloudPoint c{pos, mot, rgb, false, cv::Vec3f()};
            if (ego) {
                double om[3];
                object_motion(p, R, t, om);
                c.has_object_motion = true;
                c.object_motion = cv::Vec3f(static_cast<float>(om[0]), static_cast<float>(om[1]), static_cast<float>(om[2]));
                if (!cv::checkRange(c.object_motion)) continue;
            }
            out.push_back(c);
        }
    return out;
}

void write_ply(const std::string &path, const std::vector<CloudPoint> &points, const std::string &camera_note) {
    require(camera_note.find('\n') == std::string::npos, ErrorCode::InvalidArgument, "write_ply: multi-line note");
    const bool om = !points.empty() && points[0].has_object_motion;
    for (const CloudPoint &p : points)
        require(p.has_object_motion == om, ErrorCode::InvalidArgument,
                "write_ply: either every point has its object motion or none");
    std::string buf = "ply\nformat binary_little_endian 1.0\ncomment lidarflow scene flow: position at t0 and "
                      "motion to t1 [m], left rectified camera (x right, y down, z forward)\n" +
                      (camera_note.empty() ? std::string() : "comment " + camera_note + "\n") +
                      std::string(om ? "comment omx omy omz: object motion X1 - T X0 [m], ego-motion T removed\n" : "") +
                      "element vertex " + std::to_string(points.size()) + "\n" + kHeaderProperties +
                      (om ? kObjectMotionProperties : "") + "end_header\n";
    buf.reserve(buf.size() + points.size() * (kRecordBytes + (om ? kObjectMotionBytes : 0)));
    for (const CloudPoint &p : points) {
        for (int k = 0; k < 3; ++k) put_le32(buf, p.position[k]);
        for (int k = 0; k < 3; ++k) put_le32(buf, p.motion[k]);
        for (int k = 0; k < 3; ++k) buf.push_back(static_cast<char>(p.rgb[k]));
        if (om)
            for (int k = 0; k < 3; ++k) put_le32(buf, p.object_motion[k]);
    }
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    require(out.good(), ErrorCode::Io, "cannot write " + path);
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    out.flush();
    require(out.good(), ErrorCode::Io, "cannot write " + path);
}

std::vector<CloudPoint> read_ply(const std::string &path) {
    const std::string data = read_file(path);
    const std::string end_marker = "end_header\n";
    const size_t end = data.find(end_marker);
    require(data.rfind("ply\n", 0) == 0 && end != std::string::npos, ErrorCode::Format, path + ": not a PLY file");
    const std::string header = data.substr(0, end);
    require(header.find("format binary_little_endian 1.0\n") != std::string::npos, ErrorCode::Format,
            path + ": expected a binary little-endian PLY");
    const bool om = header.find(kHeaderProperties + kObjectMotionProperties) != std::string::npos;
    require(om || header.find(kHeaderProperties) != std::string::npos, ErrorCode::Format,
            path + ": expected the vertex properties x y z dx dy dz red green blue [omx omy omz] (as lidarflow "
                   "writes them)");
    const size_t record = kRecordBytes + (om ? kObjectMotionBytes : 0);
    const size_t v = header.find("element vertex ");
    require(v != std::string::npos, ErrorCode::Format, path + ": no vertex element");
    char *stop = nullptr;
    const char *count = header.c_str() + v + 15;
    errno = 0;
    const unsigned long long n = std::strtoull(count, &stop, 10);
    require(stop != count && *stop == '\n' && *count >= '0' && *count <= '9' && errno == 0, ErrorCode::Format,
            path + ": bad vertex count");
    const size_t body = end + end_marker.size();
    // Divided, not multiplied: a count whose size wraps modulo 2^64 could match any file size.
    require(n <= (data.size() - body) / record, ErrorCode::Format,
            path + ": vertex count " + std::to_string(n) + " needs more than the file's " +
                std::to_string(data.size() - body) + " bytes of vertices (" + std::to_string(record) +
                " per point)");
    require(data.size() - body == n * record, ErrorCode::Format,
            path + ": " + std::to_string(data.size() - body) + " bytes of vertices, the header announces " +
                std::to_string(n) + " points");
    std::vector<CloudPoint> out(n);
    for (size_t i = 0; i < n; ++i) {
        const char *r = data.data() + body + i * record;
        for (int k = 0; k < 3; ++k) out[i].position[k] = get_le32(r + 4 * k);
        for (int k = 0; k < 3; ++k) out[i].motion[k] = get_le32(r + 12 + 4 * k);
        for (int k = 0; k < 3; ++k) out[i].rgb[k] = static_cast<uchar>(r[24 + k]);
        out[i].has_object_motion = om;
        if (om)
            for (int k = 0; k < 3; ++k) out[i].object_motion[k] = get_le32(r + kRecordBytes + 4 * k);
    }
    return out;
}

}  // namespace lidarflow::io
