// SPDX-License-Identifier: MIT
#pragma once
// Checking, decoding and encoding of the lidarflow LCM messages on the bridge's side.
//
// The C decoders lcm-gen 1.3.1 emits trust the array lengths in a message (a negative length
// makes them memcpy "forever", a huge one allocates before noticing the message is short) and
// leak on failure. So every input message is first checked here against its wire layout —
// fingerprint, the length fields (which lidarflow types place before the first array), and the
// exact total size — and only then decoded. Messages that decode are checked for consistency.
// Nothing here touches LCM itself or the estimator; only the public C ABI header is used.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lidarflow/lidarflow.h"
#include "lidarflow_calibration_t.h"
#include "lidarflow_ego_motion_t.h"
#include "lidarflow_quality_t.h"
#include "lidarflow_lidar_t.h"
#include "lidarflow_scene_flow_t.h"
#include "lidarflow_status_t.h"
#include "lidarflow_stereo_t.h"
#include "bot_core_image_t.h"
#include "bot_core_images_t.h"
#include "bot_core_pointcloud_t.h"

namespace lidarflow::bridge {

// printf into a std::string (messages of at most 511 bytes; longer ones are cut).
std::string printf_string(const char *format, ...) __attribute__((format(printf, 1, 2)));

// A decoded stereo_t that owns its arrays (released with the generated cleanup).
class StereoMessage {
public:
    StereoMessage() = default;
    ~StereoMessage();
    StereoMessage(const StereoMessage &) = delete;
    StereoMessage &operator=(const StereoMessage &) = delete;
    const lidarflow_stereo_t &msg() const { return msg_; }
    // The images as the C ABI takes them; valid while this object lives.
    lf_image_t left() const;
    lf_image_t right() const;

    // False for sources without a publisher counter (bot_core.images_t): no transport-gap count.
    bool has_frame_number() const { return has_frame_number_; }
    // A frame from bot_core images (no frame number): `header`'s scalars, the left image then the
    // right one packed in `pixels` (header.size bytes each).
    void assign_packed(const lidarflow_stereo_t &header, std::vector<uint8_t> pixels);

private:
    friend std::string decode_stereo(const void *, size_t, StereoMessage &);
    lidarflow_stereo_t msg_{};
    bool decoded_ = false;             // msg_ arrays from lcm-gen's decoder
    std::vector<uint8_t> owned_;       // else msg_.left/right point here
    bool has_frame_number_ = true;
};

struct LidarSweep;

// The fingerprint (first 8 bytes) of a raw message; 0 when it is shorter.
int64_t message_fingerprint(const void *data, size_t size);

// Decodes and checks a raw bot_core.images_t: exactly one image tagged LEFT and one RIGHT (others,
// e.g. DISPARITY, are ignored), both GRAY, RGB or BGR of the same size and format, the whole
// message walked against its declared lengths (nested metadata included) before anything is
// read. The pair becomes a stereo frame of sequence 0 at images_t.utime, packed rows, without a
// frame number. Returns "" or the problem; `out` (fresh) then holds nothing.
std::string decode_bot_images(const void *data, size_t size, StereoMessage &out);

// Walks a raw bot_core.image_t sent on its own channel (a camera per channel) as above, and
// checks its pixel format is GRAY, RGB or BGR; *utime gets its time. "" or the problem.
std::string check_bot_image(const void *data, size_t size, int64_t *utime);

// Two raw bot_core.image_t of equal utime, left and right, as one stereo frame (the checks of
// decode_bot_images: same size and format, rows repacked, no frame number). "" or the problem;
// `out` (fresh) then holds nothing.
std::string decode_bot_image_pair(const void *left, size_t left_size, const void *right, size_t right_size,
                                  StereoMessage &out);

// Checks a row-major 4x4 LiDAR -> camera transform: finite, last row 0 0 0 1. "" or the problem.
std::string check_lidar_to_camera(const double *T);

// Decodes and checks a raw bot_core.pointcloud_t (sizes walked as above, finite points) and
// moves its points into the camera frame with `lidar_to_camera` (row-major 4x4, checked with
// check_lidar_to_camera; nullptr: the message is refused, as the bridge then has no transform).
// Per-point channels are ignored. Returns "" or the problem; `out` is then unchanged.
std::string decode_bot_pointcloud(const void *data, size_t size, const double *lidar_to_camera, LidarSweep &out);

// Decodes and checks a raw stereo_t into `out` (which must be fresh). Returns "" on success,
// else one line saying what is wrong (truncated, wrong size, bad fingerprint, inconsistent
// dimensions, unknown pixel format); `out` then holds nothing.
std::string decode_stereo(const void *data, size_t size, StereoMessage &out);

// A LiDAR sweep converted for the C ABI: packed float32 triples of kind LF_LIDAR_POINTS_CAMERA
// (FRAME_CAMERA, and FRAME_LIDAR moved by the message's transform) or LF_LIDAR_DISPARITY.
struct LidarSweep {
    int64_t utime = 0;
    int32_t kind = LF_LIDAR_NONE;
    std::vector<float> xyz;
    lf_lidar_t view() const;  // borrows xyz
    // Sweeps in the LiDAR frame (lidar_t FRAME_LIDAR, bot_core.pointcloud_t) also keep the points
    // as sent and their transform: an estimator whose calibration carries this transform takes
    // them as LF_LIDAR_POINTS_LIDAR and moves them in double without a float cast in between,
    // which gives exactly what projecting the scan gives (xyz alone differs by float rounding,
    // and the estimator's discrete decisions can turn that into visible differences).
    bool in_lidar_frame = false;
    std::vector<float> lidar_xyz;
    double lidar_to_camera[16] = {};
    lf_lidar_t lidar_frame_view() const;  // borrows lidar_xyz; LF_LIDAR_POINTS_LIDAR
};

// Decodes, checks (frame, finite values, rigid transform with last row 0 0 0 1, transformed
// points within float range) and converts a raw lidar_t. Returns "" on success, else one line
// saying what is wrong; `out` is then unchanged.
std::string decode_lidar(const void *data, size_t size, LidarSweep &out);

// Decodes and checks a raw calibration_t into *out (finite values, fx, fy, baseline > 0,
// width and height >= 0). Returns "" or the problem. *width/*height get the image size (0 = any).
std::string decode_calibration(const void *data, size_t size, lf_calibration_t *out, int32_t *width,
                               int32_t *height);

// The calibration message of `cal` for images width x height (0 = any).
lidarflow_calibration_t calibration_message(const lf_calibration_t &cal, int64_t utime, int32_t width,
                                            int32_t height);

// Encoding of the published scene flow.
enum class FlowEncoding { Float32 = LIDARFLOW_SCENE_FLOW_T_ENCODING_FLOAT32, Int16 = LIDARFLOW_SCENE_FLOW_T_ENCODING_INT16 };

// "float32" / "int16" -> encoding; returns false for anything else.
bool parse_flow_encoding(const std::string &name, FlowEncoding *out);

// Fixed-point scale of ENCODING_INT16 [px per unit].
constexpr float kInt16Scale = 1.0f / 64.0f;

// The planes of one scene_flow_t, owned; message() points into them.
struct FlowMessage {
    lidarflow_scene_flow_t header{};  // every scalar field; arrays are set by message()
    std::vector<uint8_t> u, v, d0, d1, valid;
    // The message to encode/publish; valid while this object lives and is not modified.
    lidarflow_scene_flow_t message();
};

// Fills the planes and the size fields of `out` from a result of the C ABI (views of
// lf_get_result_views), subsampled by `step` (1..16) and encoded as asked. Scalars other than
// sizes, step, encoding and scale are left to the caller. Throws nothing; returns false (and
// sets *error) for a step out of range or views without data.
bool encode_flow(const lf_result_views_t &views, FlowEncoding encoding, int step, FlowMessage &out,
                 std::string *error);

// Encoded bytes of a message (lcm-gen's encoder).
std::vector<uint8_t> encode_scene_flow(lidarflow_scene_flow_t &msg);

// The t1 time (utime) of a raw scene_flow_t, read without decoding the planes; false when the
// message is not a scene_flow_t or too short.
bool scene_flow_utime(const void *data, size_t size, int64_t *utime);

// A decoded scene_flow_t as float planes (the receiver's view): values in px, valid 0/1.
struct DecodedFlow {
    lidarflow_scene_flow_t header{};  // scalars only (array pointers cleared)
    std::vector<float> u, v, d0, d1;
    std::vector<uint8_t> valid;
};

// Decodes a raw scene_flow_t (checked like the inputs, and for consistent plane sizes,
// step 1..16, valid bytes 0/1 and an int16 scale that is finite and > 0) into float planes.
// Returns "" or the problem.
std::string decode_scene_flow(const void *data, size_t size, DecodedFlow &out);

// A decoded status_t: every scalar in `fields` (its last_error pointer cleared), the string in
// last_error.
struct StatusMessage {
    lidarflow_status_t fields{};
    std::string last_error;
};

// Decodes a raw status_t, checked like the inputs (and for a NUL-terminated last_error).
// Returns "" or the problem.
std::string decode_status(const void *data, size_t size, StatusMessage &out);

// ego_motion_t of a result: header fields from the caller, the rest from lf_get_ego_motion.
lidarflow_ego_motion_t ego_motion_message(const lf_ego_motion_t &ego, int64_t utime, int64_t utime0, int32_t sequence);

// Encoded bytes of a message (lcm-gen's encoder).
std::vector<uint8_t> encode_ego_motion(lidarflow_ego_motion_t &msg);

// Encoded quality_t of a result: header fields from the caller, flags and reason from
// lf_get_quality. Empty when encoding failed.
std::vector<uint8_t> encode_quality(int64_t utime, int64_t utime0, int32_t sequence, uint32_t flags, const char *reason);

// Decodes a raw ego_motion_t, checked like the inputs, then: state one of STATE_*; transform
// finite with last row 0 0 0 1; its 3x3 block a proper rotation (R^T R within 1e-6 of I per
// entry, det R > 0) when STATE_OK, else the identity; 0 <= inliers <= candidates. Returns "" or
// the problem.
std::string decode_ego_motion(const void *data, size_t size, lidarflow_ego_motion_t &out);

}  // namespace lidarflow::bridge
