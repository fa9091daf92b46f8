// SPDX-License-Identifier: MIT
// lf_create / lf_destroy / lf_push_frame / lf_reset: the estimator handle of the C ABI. A push
// builds the new frame and result aside and commits them only when everything succeeded, so a
// failed call leaves the handle exactly as it was.
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "convert.hpp"
#include "core/log.hpp"
#include "core/size_text.hpp"
#include "guard.hpp"
#include "handles.hpp"

using lidarflow::ErrorCode;
using lidarflow::require;
using lidarflow::size_text;
using namespace lidarflow::capi;
using lidarflow::pipeline::OptionValues;

namespace {

ErrorSink sink_of(lf_estimator_t *h) { return ErrorSink(h ? &h->error : nullptr); }

// Holds the handle's busy flag for one mutating call; throws BadState when another holds it.
class BusyScope {
public:
    BusyScope(lf_estimator_t *e, const char *call) : e_(e) {
        require(!e_->busy.exchange(true), ErrorCode::BadState,
                std::string(call) + ": the estimator is inside another call (lf_push_frame or lf_reset, e.g. "
                                    "from its log callback); the handle allows one call at a time");
    }
    ~BusyScope() { e_->busy.store(false); }
    BusyScope(const BusyScope &) = delete;
    BusyScope &operator=(const BusyScope &) = delete;

private:
    lf_estimator_t *e_;
};

const char *format_text(int type) { return type == CV_8UC1 ? "gray" : "colour"; }

// The result the C ABI serves: the last stage's field, continuous, with a confidence plane; u,
// v, d0, d1 are NaN and confidence 0 wherever the field is not valid (docs/CONVENTIONS.md).
std::unique_ptr<Result> make_result(const lidarflow::pipeline::EstimatorResult &r, int64_t t0, int64_t t1) {
    auto out = std::make_unique<Result>();
    const lidarflow::SceneFlowField &f = r.output();
    const cv::Mat1b invalid = f.valid == 0;
    auto plane = [&](const cv::Mat1f &m, float hole) {
        cv::Mat1f c = m.empty() ? cv::Mat1f::zeros(f.valid.size()) : m.clone();
        c.setTo(hole, invalid);
        return c;
    };
    const float nan = std::numeric_limits<float>::quiet_NaN();
    out->field.u = plane(f.u, nan);
    out->field.v = plane(f.v, nan);
    out->field.d0 = plane(f.d0, nan);
    out->field.d1 = plane(f.d1, nan);
    out->field.confidence = plane(f.confidence, 0.0f);
    out->field.valid = (f.valid != 0) / 255;
    out->stage = r.last_stage;
    out->t0_us = t0;
    out->t1_us = t1;
    out->timings = r.timings;
    out->total_seconds = r.total_seconds;
    out->ego = r.ego;
    out->ego_state = r.ego_state;
    out->quality = r.quality;
    return out;
}

}  // namespace

extern "C" {

LF_API int32_t lf_create(const lf_options_t *options, const lf_calibration_t *calibration, lf_estimator_t **out) {
    return guarded(ErrorSink(nullptr), "lf_create", [&] {
        require_non_null(out, "out");
        *out = nullptr;
        require_non_null(calibration, "calibration");
        const Calibration cal = convert_calibration(*calibration);
        const OptionValues defaults;
        const OptionValues &values = options ? options->values : defaults;
        lidarflow::pipeline::EstimatorOptions estimator_options = values.estimator;
        estimator_options.keep_stage_fields = false;  // a result holds the output field only
        *out = new lf_estimator(estimator_options, cal);
        (*out)->strict_input = values.estimator.strict_input;
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API void lf_destroy(lf_estimator_t *estimator) { delete estimator; }

LF_API int32_t lf_push_frame(lf_estimator_t *estimator, int64_t timestamp_us, const lf_image_t *left,
                             const lf_image_t *right, const lf_lidar_t *lidar) {
    return guarded(sink_of(estimator), "lf_push_frame", [&] {
        require_non_null(estimator, "estimator");
        require_non_null(left, "left");
        require_non_null(right, "right");
        const BusyScope busy(estimator, "lf_push_frame");
        char context[80];
        std::snprintf(context, sizeof context, "estimator %p frame %lld us", static_cast<void *>(estimator),
                      static_cast<long long>(timestamp_us));
        const lidarflow::log::Scope log_scope(context);
        const Frame *prev = estimator->previous.get();
        require(!prev || timestamp_us > prev->timestamp_us, ErrorCode::InvalidArgument,
                "timestamp " + std::to_string(timestamp_us) + " us is not after the previous frame's (" +
                    (prev ? std::to_string(prev->timestamp_us) : std::string()) + " us)");
        require(left->format == right->format, ErrorCode::InvalidArgument,
                "left and right have different formats (" + std::to_string(left->format) + " and " +
                    std::to_string(right->format) + ")");

        auto frame = std::make_unique<Frame>();
        frame->timestamp_us = timestamp_us;
        frame->left = convert_image(*left, "left");
        frame->right = convert_image(*right, "right");
        const cv::Size size = frame->left.size();
        require(frame->right.size() == size, ErrorCode::SizeMismatch,
                "left is " + size_text(size) + " but right is " + size_text(frame->right.size()));
        if (prev) {
            require(prev->left.size() == size, ErrorCode::SizeMismatch,
                    "frame is " + size_text(size) + " but the previous frame was " + size_text(prev->left.size()) +
                        " (call lf_reset to start a sequence of another size)");
            require(prev->left.type() == frame->left.type(), ErrorCode::SizeMismatch,
                    std::string("frame is ") + format_text(frame->left.type()) + " but the previous frame was " +
                        format_text(prev->left.type()) + " (call lf_reset to change the format)");
        }
        const lidarflow::io::Rig &rig = estimator->calibration.rig;
        const std::string mismatch = lidarflow::io::image_size_mismatch(rig.rect.image_size, size);
        require(mismatch.empty() || !estimator->strict_input, ErrorCode::SizeMismatch,
                mismatch + " (option input.strict refuses it)");
        const bool warn_size = !mismatch.empty() && !estimator->size_warned;
        if (warn_size)
            lidarflow::log::write(lidarflow::log::Level::Warning,
                                  mismatch + ": results use the calibration as it is (said once per estimator)");
        std::shared_ptr<const lidarflow::io::Rectifier> rectifier = estimator->rectifier;
        const auto rectify_start = std::chrono::steady_clock::now();
        if (rig.rectify) {
            if (!rectifier || rectifier->size() != size)
                rectifier = std::make_shared<const lidarflow::io::Rectifier>(rig, size);
            rectifier->apply(frame->left, frame->right, frame->left, frame->right);
        }
        const double rectify_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - rectify_start).count();
        frame->lidar = convert_lidar(lidar, size, estimator->calibration);

        std::unique_ptr<Result> result;
        if (prev) {
            lidarflow::pipeline::FrameInput in;
            in.left0 = prev->left;
            in.right0 = prev->right;
            in.left1 = frame->left;
            in.right1 = frame->right;
            in.lidar0 = prev->lidar;
            in.lidar1 = frame->lidar;
            in.camera = estimator->calibration.camera;
            in.calibration_size = rig.rect.image_size;
            in.step_us = timestamp_us - prev->timestamp_us;
            result = make_result(estimator->estimator.run(in, &estimator->stream), prev->timestamp_us, timestamp_us);
            if (rig.rectify) {
                result->rectified = true;
                result->timings.insert(result->timings.begin(), {"rectify", rectify_seconds});
                result->total_seconds += rectify_seconds;
            }
        }
        // Commit: nothing below can throw.
        if (result) estimator->result = std::move(result);
        estimator->previous = std::move(frame);
        estimator->rectifier = std::move(rectifier);
        estimator->size_warned = estimator->size_warned || warn_size;
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_reset(lf_estimator_t *estimator) {
    return guarded(sink_of(estimator), "lf_reset", [&] {
        require_non_null(estimator, "estimator");
        const BusyScope busy(estimator, "lf_reset");
        estimator->previous.reset();
        estimator->result.reset();
        estimator->stream.clear();
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_has_result(const lf_estimator_t *estimator) { return estimator && estimator->result ? 1 : 0; }

LF_API const char *lf_last_error(const lf_estimator_t *estimator) {
    return estimator ? estimator->error.c_str() : thread_last_error().c_str();
}

}  // extern "C"
