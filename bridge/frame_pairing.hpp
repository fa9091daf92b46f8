// SPDX-License-Identifier: MIT
#pragma once
// What the bridge pairs its inputs with before a stereo frame reaches the estimator: the images
// of two camera channels into stereo frames (equal utime), each frame with the camera of the
// calibration channel, and with the nearest buffered LiDAR sweep.
//
// Thread-safety: none of its own. The bridge calls every member with its mutex held. Counting
// and logging stay with the bridge: members report what happened (an image dropped, a size
// mismatch) and the bridge counts it.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

#include "lidarflow/lidarflow.h"
#include "wire.hpp"

namespace lidarflow::bridge {

class FramePairing {
public:
    // pair_buffer: images waiting per camera (oldest dropped); lidar_buffer: sweeps kept (oldest
    // dropped); lidar_tolerance_us: largest |t_lidar - t_stereo| of a pair.
    FramePairing(int pair_buffer, int lidar_buffer, int64_t lidar_tolerance_us)
        : pair_buffer_(pair_buffer), lidar_buffer_(lidar_buffer), lidar_tolerance_us_(lidar_tolerance_us) {}

    // An image that leaves without a partner: its camera (0 left, 1 right), utime and why.
    struct Unpaired {
        int side;
        int64_t utime;
        const char *why;
    };
    enum class ImageOutcome {
        Waiting,  // kept until its partner comes (images pushed out of the buffer in *unpaired)
        Paired,   // *partner holds the other camera's image of equal utime, taken from the buffer
        Twin,     // a second image of this camera at this utime: it has no partner of its own
    };
    // One camera's raw image (`size` bytes, copied when kept) arriving at `arrival` [s].
    ImageOutcome offer_image(int side, int64_t utime, double arrival, const uint8_t *data, size_t size,
                             std::vector<uint8_t> *partner, std::vector<Unpaired> *unpaired);
    // Images that arrived before `deadline` [s] leave unpaired, oldest first per camera.
    void expire_images(double deadline, std::vector<Unpaired> *unpaired);
    // Every waiting image leaves unpaired (`why`), left camera first.
    void drop_all_images(const char *why, std::vector<Unpaired> *unpaired);

    // Keeps a decoded sweep; returns how many are buffered.
    size_t add_lidar(std::shared_ptr<const LidarSweep> sweep);
    // The buffered sweep nearest to `utime` within the tolerance (the first of equals), or null.
    std::shared_ptr<const LidarSweep> lidar_for(int64_t utime) const;

    // A camera from the calibration channel (width, height: 0 = any size). Returns true when it
    // differs from the one held (worth a log line).
    bool set_calibration(const lf_calibration_t &cal, int32_t width, int32_t height);
    enum class CalibrationOutcome { None, SizeMismatch, Ok };
    // The channel's camera for a frame of width x height: None before any calibration,
    // SizeMismatch when the calibration names another size, else Ok and *out set.
    CalibrationOutcome calibration_for(int32_t width, int32_t height, lf_calibration_t *out) const;
    int32_t calibration_width() const { return calibration_width_; }
    int32_t calibration_height() const { return calibration_height_; }

private:
    struct WaitingImage {
        int64_t utime;
        double arrival;
        std::vector<uint8_t> bytes;
    };
    void drop_oldest(int side, const char *why, std::vector<Unpaired> *unpaired);

    int pair_buffer_, lidar_buffer_;
    int64_t lidar_tolerance_us_;
    std::deque<WaitingImage> waiting_[2];  // left (0) and right (1) images, oldest first
    std::deque<std::shared_ptr<const LidarSweep>> lidar_;
    bool have_calibration_ = false;
    lf_calibration_t calibration_{};
    int32_t calibration_width_ = 0, calibration_height_ = 0;
};

}  // namespace lidarflow::bridge
