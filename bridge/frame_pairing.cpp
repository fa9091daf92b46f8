// SPDX-License-Identifier: MIT
#include "frame_pairing.hpp"

#include <algorithm>

namespace lidarflow::bridge {

FramePairing::ImageOutcome FramePairing::offer_image(int side, int64_t utime, double arrival, const uint8_t *data,
                                                     size_t size, std::vector<uint8_t> *partner,
                                                     std::vector<Unpaired> *unpaired) {
    std::deque<WaitingImage> &mine = waiting_[side], &other = waiting_[1 - side];
    const auto match = std::find_if(other.begin(), other.end(), [&](const WaitingImage &w) { return w.utime == utime; });
    if (match == other.end()) {
        const auto twin = std::find_if(mine.begin(), mine.end(), [&](const WaitingImage &w) { return w.utime == utime; });
        // Two images of one camera at one time: the later one cannot be told apart.
        if (twin != mine.end()) return ImageOutcome::Twin;
        mine.push_back({utime, arrival, std::vector<uint8_t>(data, data + size)});
        while (static_cast<int>(mine.size()) > pair_buffer_)
            drop_oldest(side, "more images waiting than --pair-buffer", unpaired);
        return ImageOutcome::Waiting;
    }
    *partner = std::move(match->bytes);
    other.erase(match);
    return ImageOutcome::Paired;
}

void FramePairing::drop_oldest(int side, const char *why, std::vector<Unpaired> *unpaired) {
    unpaired->push_back({side, waiting_[side].front().utime, why});
    waiting_[side].pop_front();
}

void FramePairing::expire_images(double deadline, std::vector<Unpaired> *unpaired) {
    for (int side = 0; side < 2; ++side)
        while (!waiting_[side].empty() && waiting_[side].front().arrival < deadline)
            drop_oldest(side, "waited --pair-wait-ms", unpaired);
}

void FramePairing::drop_all_images(const char *why, std::vector<Unpaired> *unpaired) {
    for (int side = 0; side < 2; ++side)
        while (!waiting_[side].empty()) drop_oldest(side, why, unpaired);
}

size_t FramePairing::add_lidar(std::shared_ptr<const LidarSweep> sweep) {
    lidar_.push_back(std::move(sweep));
    while (static_cast<int>(lidar_.size()) > lidar_buffer_) lidar_.pop_front();
    return lidar_.size();
}

std::shared_ptr<const LidarSweep> FramePairing::lidar_for(int64_t utime) const {
    std::shared_ptr<const LidarSweep> best;
    int64_t best_dt = 0;
    for (const auto &s : lidar_) {
        const int64_t dt = s->utime > utime ? s->utime - utime : utime - s->utime;
        if (dt <= lidar_tolerance_us_ && (!best || dt < best_dt)) {
            best = s;
            best_dt = dt;
        }
    }
    return best;
}

bool FramePairing::set_calibration(const lf_calibration_t &cal, int32_t width, int32_t height) {
    const bool same = have_calibration_ && cal.fx == calibration_.fx && cal.fy == calibration_.fy &&
                      cal.cx == calibration_.cx && cal.cy == calibration_.cy &&
                      cal.baseline == calibration_.baseline && width == calibration_width_ &&
                      height == calibration_height_;
    have_calibration_ = true;
    calibration_ = cal;
    calibration_width_ = width;
    calibration_height_ = height;
    return !same;
}

FramePairing::CalibrationOutcome FramePairing::calibration_for(int32_t width, int32_t height,
                                                               lf_calibration_t *out) const {
    if (!have_calibration_) return CalibrationOutcome::None;
    if ((calibration_width_ && calibration_width_ != width) || (calibration_height_ && calibration_height_ != height))
        return CalibrationOutcome::SizeMismatch;
    *out = calibration_;
    return CalibrationOutcome::Ok;
}

}  // namespace lidarflow::bridge
