// SPDX-License-Identifier: MIT
#include "flow_reference.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>

namespace lidarflow::bridge::testing {

std::string check_flow(const std::vector<std::pair<std::string, std::string>> &options, const lf_calibration_t &cal,
                       const Inputs &inputs, const std::vector<uint8_t> &flow_bytes) {
    DecodedFlow got;
    std::string err = decode_scene_flow(flow_bytes.data(), flow_bytes.size(), got);
    if (!err.empty()) return "published flow does not decode: " + err;
    const lidarflow_scene_flow_t &h = got.header;
    const auto s0 = inputs.stereo.find(h.utime0), s1 = inputs.stereo.find(h.utime);
    if (s0 == inputs.stereo.end() || s1 == inputs.stereo.end()) return "flow names stereo frames that were not sent";
    StereoMessage m0, m1;
    if (!decode_stereo(s0->second.data(), s0->second.size(), m0).empty() ||
        !decode_stereo(s1->second.data(), s1->second.size(), m1).empty())
        return "stereo input does not decode";
    LidarSweep l[2];
    const bool has[2] = {(h.lidar_flags & LIDARFLOW_SCENE_FLOW_T_LIDAR_T0) != 0,
                         (h.lidar_flags & LIDARFLOW_SCENE_FLOW_T_LIDAR_T1) != 0};
    const int64_t lt[2] = {h.lidar_utime0, h.lidar_utime1};
    for (int k = 0; k < 2; ++k) {
        if (!has[k]) continue;
        const auto it = inputs.lidar.find(lt[k]);
        if (it == inputs.lidar.end()) return "flow names a LiDAR sweep that was not sent";
        if (!decode_lidar(it->second.data(), it->second.size(), l[k]).empty()) return "LiDAR input does not decode";
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
    lf_estimator_t *e = nullptr;
    const int32_t created = lf_create(opt, &cal, &e);
    lf_options_destroy(opt);
    if (created != LF_OK) return std::string("lf_create: ") + lf_last_error(nullptr);
    std::unique_ptr<lf_estimator_t, void (*)(lf_estimator_t *)> guard(e, lf_destroy);
    const lf_image_t a0 = m0.left(), b0 = m0.right(), a1 = m1.left(), b1 = m1.right();
    const lf_lidar_t v0 = l[0].view(), v1 = l[1].view();
    if (lf_push_frame(e, h.utime0, &a0, &b0, has[0] ? &v0 : nullptr) != LF_OK ||
        lf_push_frame(e, h.utime, &a1, &b1, has[1] ? &v1 : nullptr) != LF_OK)
        return std::string("lf_push_frame: ") + lf_last_error(e);
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
