// SPDX-License-Identifier: MIT
#include "flow_reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>

namespace lidarflow::bridge::testing {
namespace {

// The reference's estimator and the frame it saw last (a flow's t1 frame).
struct ReferenceStream {
    std::unique_ptr<lf_estimator_t, void (*)(lf_estimator_t *)> estimator{nullptr, lf_destroy};
    std::vector<std::pair<std::string, std::string>> options;
    lf_calibration_t calibration{};
    std::vector<uint8_t> t1_stereo, t1_lidar;
    bool t1_has_lidar = false;
};

// One frame's images as the C ABI takes them, with the bytes they point into.
struct RefFrame {
    StereoMessage own;
    std::vector<uint8_t> left_bytes, right_bytes;
    lf_image_t left{}, right{};
};

// lcm-gen's decoder for a bot_core.images_t: the LEFT and RIGHT entries as they are, row stride
// included (the C ABI takes any stride; the bridge repacks rows, so equal results also check that).
std::string reference_bot_images(const std::vector<uint8_t> &raw, RefFrame &f) {
    bot_core_images_t m;
    if (bot_core_images_t_decode(raw.data(), 0, static_cast<int>(raw.size()), &m) < 0)
        return "bot_core.images_t does not decode (lcm-gen)";
    std::string err;
    for (int i = 0; i < m.n_images; ++i) {
        const bot_core_image_t &im = m.images[i];
        const int role = m.image_types[i];
        if (role != BOT_CORE_IMAGES_T_LEFT && role != BOT_CORE_IMAGES_T_RIGHT) continue;
        lf_image_t v{};
        v.width = static_cast<uint32_t>(im.width);
        v.height = static_cast<uint32_t>(im.height);
        v.stride_bytes = static_cast<uint64_t>(im.row_stride);
        v.format = im.pixelformat == BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY  ? LF_PIXEL_GRAY8
                   : im.pixelformat == BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB ? LF_PIXEL_RGB8
                   : im.pixelformat == BOT_CORE_IMAGE_T_PIXEL_FORMAT_BGR ? LF_PIXEL_BGR8
                                                                          : 0;
        if (!v.format) err = "unsupported pixel format";
        std::vector<uint8_t> &bytes = role == BOT_CORE_IMAGES_T_LEFT ? f.left_bytes : f.right_bytes;
        bytes.assign(im.data, im.data + im.size);
        v.data = bytes.data();
        (role == BOT_CORE_IMAGES_T_LEFT ? f.left : f.right) = v;
    }
    bot_core_images_t_decode_cleanup(&m);
    if (err.empty() && (!f.left.data || !f.right.data)) err = "no LEFT or RIGHT image";
    return err;
}

std::string reference_frame(const std::vector<uint8_t> &raw, RefFrame &f) {
    if (message_fingerprint(raw.data(), raw.size()) == __bot_core_images_t_get_hash()) return reference_bot_images(raw, f);
    if (!decode_stereo(raw.data(), raw.size(), f.own).empty()) return "stereo input does not decode";
    f.left = f.own.left();
    f.right = f.own.right();
    return "";
}

// A bot_core.pointcloud_t's points as sent, with the --lidar-to-camera transform (the C ABI
// moves them, as the bridge has it do), and moved here as the bridge's fallback does: T * (x, y,
// z, 1) in double, one cast to float.
std::string reference_bot_pointcloud(const std::vector<uint8_t> &raw, const Inputs &inputs, LidarSweep &out) {
    if (!inputs.have_lidar_to_camera) return "a pointcloud_t input but no lidar_to_camera given";
    bot_core_pointcloud_t m;
    if (bot_core_pointcloud_t_decode(raw.data(), 0, static_cast<int>(raw.size()), &m) < 0)
        return "bot_core.pointcloud_t does not decode (lcm-gen)";
    const double *T = inputs.lidar_to_camera;
    out.utime = m.utime;
    out.kind = LF_LIDAR_POINTS_CAMERA;
    out.in_lidar_frame = true;
    std::copy(T, T + 16, out.lidar_to_camera);
    out.xyz.clear();
    out.lidar_xyz.clear();
    for (int i = 0; i < m.n_points; ++i) {
        const double x = m.points[i][0], y = m.points[i][1], z = m.points[i][2];
        out.lidar_xyz.insert(out.lidar_xyz.end(), {m.points[i][0], m.points[i][1], m.points[i][2]});
        for (int r = 0; r < 3; ++r)
            out.xyz.push_back(static_cast<float>(T[4 * r] * x + T[4 * r + 1] * y + T[4 * r + 2] * z + T[4 * r + 3]));
    }
    bot_core_pointcloud_t_decode_cleanup(&m);
    return "";
}

}  // namespace

bool bot_core_utime(const std::vector<uint8_t> &raw, int64_t *utime) {
    const int64_t fp = message_fingerprint(raw.data(), raw.size());
    if (fp == __bot_core_images_t_get_hash()) {
        bot_core_images_t m;
        if (bot_core_images_t_decode(raw.data(), 0, static_cast<int>(raw.size()), &m) < 0) return false;
        *utime = m.utime;
        bot_core_images_t_decode_cleanup(&m);
        return true;
    }
    if (fp == __bot_core_pointcloud_t_get_hash()) {
        bot_core_pointcloud_t m;
        if (bot_core_pointcloud_t_decode(raw.data(), 0, static_cast<int>(raw.size()), &m) < 0) return false;
        *utime = m.utime;
        bot_core_pointcloud_t_decode_cleanup(&m);
        return true;
    }
    return false;
}

std::string check_flow(const std::vector<std::pair<std::string, std::string>> &options, const lf_calibration_t &cal,
                       const Inputs &inputs, const std::vector<uint8_t> &flow_bytes) {
    DecodedFlow got;
    std::string err = decode_scene_flow(flow_bytes.data(), flow_bytes.size(), got);
    if (!err.empty()) return "published flow does not decode: " + err;
    const lidarflow_scene_flow_t &h = got.header;
    const auto s0 = inputs.stereo.find(h.utime0), s1 = inputs.stereo.find(h.utime);
    if (s0 == inputs.stereo.end() || s1 == inputs.stereo.end()) return "flow names stereo frames that were not sent";
    RefFrame f0, f1;
    err = reference_frame(s0->second, f0);
    if (err.empty()) err = reference_frame(s1->second, f1);
    if (!err.empty()) return err;
    LidarSweep l[2];
    const bool has[2] = {(h.lidar_flags & LIDARFLOW_SCENE_FLOW_T_LIDAR_T0) != 0,
                         (h.lidar_flags & LIDARFLOW_SCENE_FLOW_T_LIDAR_T1) != 0};
    const int64_t lt[2] = {h.lidar_utime0, h.lidar_utime1};
    for (int k = 0; k < 2; ++k) {
        if (!has[k]) continue;
        const auto it = inputs.lidar.find(lt[k]);
        if (it == inputs.lidar.end()) return "flow names a LiDAR sweep that was not sent";
        if (message_fingerprint(it->second.data(), it->second.size()) == __bot_core_pointcloud_t_get_hash()) {
            err = reference_bot_pointcloud(it->second, inputs, l[k]);
            if (!err.empty()) return err;
        } else if (!decode_lidar(it->second.data(), it->second.size(), l[k]).empty()) {
            return "LiDAR input does not decode";
        }
    }
    lf_options_t *opt = nullptr;
    lf_options_create(&opt);
    for (const auto &[key, value] : options) {
        char *end = nullptr;
        const long long i = std::strtoll(value.c_str(), &end, 10);
        int32_t st = *end == '\0' ? lf_options_set_int(opt, key.c_str(), i) : LF_ERR_INVALID_ARGUMENT;
        if (st != LF_OK) st = lf_options_set_float(opt, key.c_str(), std::strtod(value.c_str(), nullptr));
        if (st != LF_OK) lf_options_set_string(opt, key.c_str(), value.c_str());
    }
    // As the bridge in a steady stream: the estimator carries the transform of the LiDAR-frame
    // sweeps (the t0 one's first) and is given those points in the LiDAR frame.
    lf_calibration_t with_transform = cal;
    for (int k = 1; k >= 0; --k)
        if (has[k] && l[k].in_lidar_frame) {
            std::copy(l[k].lidar_to_camera, l[k].lidar_to_camera + 16, with_transform.lidar_to_camera);
            with_transform.has_lidar_to_camera = 1;
        }
    lf_lidar_t v[2];
    for (int k = 0; k < 2; ++k)
        v[k] = l[k].in_lidar_frame && with_transform.has_lidar_to_camera &&
                       std::equal(l[k].lidar_to_camera, l[k].lidar_to_camera + 16, with_transform.lidar_to_camera)
                   ? l[k].lidar_frame_view()
                   : l[k].view();
    // As the bridge's stream: a flow whose t0 frame (images, sweep, settings) is the previous
    // flow's t1 frame continues that estimator, whose stream priors it then shares.
    static ReferenceStream stream;
    const std::vector<uint8_t> *l1 = has[1] ? &inputs.lidar.find(lt[1])->second : nullptr;
    const std::vector<uint8_t> *l0 = has[0] ? &inputs.lidar.find(lt[0])->second : nullptr;
    const bool continues = stream.estimator && stream.options == options &&
                           std::memcmp(&stream.calibration, &with_transform, sizeof with_transform) == 0 &&
                           stream.t1_stereo == s0->second && stream.t1_lidar == (l0 ? *l0 : std::vector<uint8_t>{}) &&
                           stream.t1_has_lidar == has[0];
    if (!continues) {
        stream = ReferenceStream{};
        lf_estimator_t *e = nullptr;
        const int32_t created = lf_create(opt, &with_transform, &e);
        if (created != LF_OK) {
            lf_options_destroy(opt);
            return std::string("lf_create: ") + lf_last_error(nullptr);
        }
        stream.estimator.reset(e);
    }
    lf_options_destroy(opt);
    lf_estimator_t *e = stream.estimator.get();
    const lf_image_t a0 = f0.left, b0 = f0.right, a1 = f1.left, b1 = f1.right;
    if ((!continues && lf_push_frame(e, h.utime0, &a0, &b0, has[0] ? &v[0] : nullptr) != LF_OK) ||
        lf_push_frame(e, h.utime, &a1, &b1, has[1] ? &v[1] : nullptr) != LF_OK) {
        const std::string err = std::string("lf_push_frame: ") + lf_last_error(e);
        stream = ReferenceStream{};
        return err;
    }
    stream.options = options;
    stream.calibration = with_transform;
    stream.t1_stereo = s1->second;
    stream.t1_lidar = l1 ? *l1 : std::vector<uint8_t>{};
    stream.t1_has_lidar = has[1];
    lf_result_views_t views;
    lf_result_views_init(&views);
    if (lf_get_result_views(e, &views) != LF_OK) return std::string("lf_get_result_views: ") + lf_last_error(e);
    FlowMessage expected;
    if (!encode_flow(views, static_cast<FlowEncoding>(h.encoding), h.step, expected, &err)) return err;
    expected.header.utime = h.utime;
    lidarflow_scene_flow_t msg = expected.message();
    const std::vector<uint8_t> bytes = encode_scene_flow(msg);
    DecodedFlow want;
    err = decode_scene_flow(bytes.data(), bytes.size(), want);
    if (!err.empty()) return err;
    if (want.header.width != h.width || want.header.height != h.height) return "plane sizes differ";
    const std::vector<float> *gp[4] = {&got.u, &got.v, &got.d0, &got.d1}, *wp[4] = {&want.u, &want.v, &want.d0, &want.d1};
    const char *names[4] = {"u", "v", "d0", "d1"};
    for (int k = 0; k < 4; ++k)
        if (std::memcmp(gp[k]->data(), wp[k]->data(), gp[k]->size() * sizeof(float)) != 0)
            return std::string("plane ") + names[k] + " differs from the C ABI result";
    if (got.valid != want.valid) return "valid plane differs from the C ABI result";
    // Float32 must be the C ABI's values bit for bit (not just the same after our encoding).
    if (h.encoding == LIDARFLOW_SCENE_FLOW_T_ENCODING_FLOAT32 && h.step == 1) {
        for (int y = 0; y < h.height; ++y)
            if (std::memcmp(got.u.data() + static_cast<size_t>(y) * h.width,
                            static_cast<const uint8_t *>(views.u.data) + y * views.u.stride_bytes,
                            sizeof(float) * h.width) != 0)
                return "float32 u differs from lf_get_result_views";
    }
    return "";
}

}  // namespace lidarflow::bridge::testing
