// SPDX-License-Identifier: MIT
// lf_create / lf_destroy / lf_push_frame / lf_flush / lf_reset: the estimator handle of the C ABI.
// A push builds the new frame and result aside and commits them only when everything succeeded,
// so a failed call leaves the handle exactly as it was; with frames in flight, a pair's own
// failure is handed over in place of its result, and the result readers report it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <string>

#include "convert.hpp"
#include "core/error_of.hpp"
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

// Holds the handle's busy flag for one mutating call; throws BadState when another holds it.
class BusyScope {
public:
    BusyScope(lf_estimator_t *e, const char *call) : e_(e) {
        // From a frame worker of this handle, waiting for its own pair would never return.
        require(pair_owner != e_ && !e_->busy.exchange(true), ErrorCode::BadState,
                std::string(call) + ": the estimator is inside another call (lf_push_frame, lf_flush or lf_reset, "
                                    "e.g. from its log callback); the handle allows one call at a time");
    }
    ~BusyScope() { e_->busy.store(false); }
    BusyScope(const BusyScope &) = delete;
    BusyScope &operator=(const BusyScope &) = delete;

private:
    lf_estimator_t *e_;
};

const char *format_text(int type) { return type == CV_8UC1 ? "gray" : "colour"; }

// to - from for timestamps with to > from, saturated: any two int64 values may be pushed.
int64_t elapsed_us(int64_t from, int64_t to) {
    const uint64_t d = static_cast<uint64_t>(to) - static_cast<uint64_t>(from);
    return d > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) ? std::numeric_limits<int64_t>::max()
                                                                          : static_cast<int64_t>(d);
}

// The result the C ABI serves: the last stage's field, continuous, with a confidence plane; u,
// v, d0, d1 are NaN and confidence 0 wherever the field is not valid (docs/CONVENTIONS.md).
// Planes the result takes over from the run's: r is consumed. A plane whose buffer nothing else
// shares (and that is continuous) is kept: copying five full-size planes a pair is avoidable.
std::unique_ptr<Result> make_result(lidarflow::pipeline::EstimatorResult &&r, int64_t t0, int64_t t1) {
    auto out = std::make_unique<Result>();
    lidarflow::SceneFlowField &f = r.output();
    auto plane = [&](cv::Mat1f &m) {
        if (m.empty()) return cv::Mat1f(cv::Mat1f::zeros(f.valid.size()));
        if (m.u && m.u->refcount == 1 && m.isContinuous()) return cv::Mat1f(std::move(m));
        return cv::Mat1f(m.clone());
    };
    lidarflow::SceneFlowField &o = out->field;
    o.u = plane(f.u);
    o.v = plane(f.v);
    o.d0 = plane(f.d0);
    o.d1 = plane(f.d1);
    o.confidence = plane(f.confidence);
    o.valid.create(f.valid.size());
    // The holes and the 0/1 mask in one pass over the rows (a result is waited for: on the
    // estimator's threads), not one pass a plane.
    const float nan = std::numeric_limits<float>::quiet_NaN();
#pragma omp parallel for schedule(static) num_threads(std::max(1, r.threads))
    for (int y = 0; y < f.valid.rows; ++y) {
        const uint8_t *in = f.valid[y];
        uint8_t *valid = o.valid[y];
        float *u = o.u[y], *v = o.v[y], *d0 = o.d0[y], *d1 = o.d1[y], *c = o.confidence[y];
        for (int x = 0; x < f.valid.cols; ++x) {
            const bool ok = in[x] != 0;
            valid[x] = ok ? 1 : 0;
            if (ok) continue;
            u[x] = v[x] = d0[x] = d1[x] = nan;
            c[x] = 0.0f;
        }
    }
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

// The scene flow of prev -> cur, as lf_push_frame serves it. cache: the stream's, or null for a
// pair on its own (frames in flight).
std::unique_ptr<Result> compute_pair(const lf_estimator_t &e, const Frame &prev, const Frame &cur,
                                     lidarflow::pipeline::StreamCache *cache, double rectify_seconds) {
    lidarflow::pipeline::FrameInput in;
    in.left0 = prev.left;
    in.right0 = prev.right;
    in.left1 = cur.left;
    in.right1 = cur.right;
    in.lidar0 = prev.lidar;
    in.lidar1 = cur.lidar;
    in.camera = e.calibration.camera;
    in.calibration_size = e.calibration.rig.rect.image_size;
    in.step_us = elapsed_us(prev.timestamp_us, cur.timestamp_us);
    std::unique_ptr<Result> result = make_result(e.estimator.run(in, cache), prev.timestamp_us, cur.timestamp_us);
    if (e.calibration.rig.rectify) {
        result->rectified = true;
        result->timings.insert(result->timings.begin(), {"rectify", rectify_seconds});
        result->total_seconds += rectify_seconds;
    }
    return result;
}

// A pair computed on a frame worker: its errors name the pair, since a later call reports them.
// `index`: its place in the sequence; `prior`: the movers of the pair `lag` before it, or null.
std::function<std::unique_ptr<Result>()> pair_job(const lf_estimator_t *e, std::shared_ptr<const Frame> prev,
                                                  std::shared_ptr<const Frame> cur, double rectify_seconds,
                                                  int64_t index, int lag,
                                                  std::shared_ptr<const lidarflow::matching::DecoupledStereo> prior) {
    return [e, prev = std::move(prev), cur = std::move(cur), rectify_seconds, index, lag, prior = std::move(prior)] {
        char context[112];
        std::snprintf(context, sizeof context, "estimator %p pair %lld -> %lld us", static_cast<const void *>(e),
                      static_cast<long long>(prev->timestamp_us), static_cast<long long>(cur->timestamp_us));
        pair_owner = e;
        struct Clear {
            ~Clear() { pair_owner = nullptr; }
        } clear;
        const lidarflow::log::Scope log_scope(context);
        try {
            lidarflow::pipeline::StreamCache cache;
            cache.set_in_flight(lag, prior);
            std::unique_ptr<Result> result = compute_pair(*e, *prev, *cur, &cache, rectify_seconds);
            result->pair_index = index;
            result->prior_for_later = cache.prior_for_later();
            return result;
        } catch (...) {  // as guarded() maps them, with the pair named
            throw lidarflow::error_of_current_exception(context);
        }
    };
}

// The oldest pair in flight: its result, or (result null) its error in *error (out of memory
// too: the call that hands it over has already started the next pair). Its motion prior is kept
// for the pair frames_in_flight after it.
std::unique_ptr<Result> take_oldest_pair(lf_estimator_t &e, std::exception_ptr *error) {
    std::future<std::unique_ptr<Result>> f = e.pool->take_oldest();
    std::unique_ptr<Result> r;
    try {
        r = f.get();
    } catch (...) {
        *error = std::current_exception();
        return nullptr;
    }
    // Out of memory here costs the later pair its prior, not this pair its result.
    try {
        if (r->prior_for_later) e.priors.push_back({r->pair_index, r->t0_us, r->t1_us, r->prior_for_later});
    } catch (const std::bad_alloc &) {
    }
    return r;
}

// The motion prior pair `index` starts from (t0_us: its first frame): that of the pair `lag`
// before it, carried lag steps of that pair's length, so only when the frames since kept that
// pace. Forgets the priors no later pair can take.
std::shared_ptr<const lidarflow::matching::DecoupledStereo> lagged_prior(lf_estimator_t &e, int64_t index, int lag,
                                                                         int64_t t0_us) {
    while (!e.priors.empty() && e.priors.front().pair_index < index - lag) e.priors.pop_front();
    if (e.priors.empty() || e.priors.front().pair_index != index - lag) return nullptr;
    const HandedPrior &h = e.priors.front();
    if (lidarflow::pipeline::lagged_prior_in_pace(static_cast<double>(h.t0_us), static_cast<double>(h.t1_us),
                                                  static_cast<double>(t0_us), lag))
        return h.prior;
    lidarflow::log::write(lidarflow::log::Level::Info, "no motion prior for this pair: the frames since the pair "
                                                       "that made it are not evenly spaced (a dropped frame?)");
    return nullptr;
}

// Estimator::prepare_first for a stream's first frame into `out`; false (logged) when it threw.
bool prepare_first_frame(const lf_estimator_t &e, const Frame &frame, lidarflow::pipeline::StreamCache &out) noexcept {
    try {
        e.estimator.prepare_first(frame.left, frame.right, frame.lidar, out);
        return true;
    } catch (const std::exception &x) {
        try {
            lidarflow::log::write(lidarflow::log::Level::Debug,
                                  std::string("the first frame was not prepared ahead of its pair: ") + x.what());
        } catch (...) {  // out of memory for the message: the pair reports what matters
        }
    } catch (...) {
    }
    return false;
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
        const int in_flight = estimator_options.frames_in_flight;
        estimator_options.threads = estimator_options.per_frame_threads();
        auto handle = std::make_unique<lf_estimator>(estimator_options, cal);
        handle->strict_input = values.estimator.strict_input;
        if (in_flight > 1)
            handle->pool = std::make_unique<lidarflow::OrderedPool<std::unique_ptr<Result>>>(in_flight);
        *out = handle.release();
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
        const std::shared_ptr<const Frame> prev_frame = estimator->previous;
        const Frame *prev = prev_frame.get();
        require(!prev || timestamp_us > prev->timestamp_us, ErrorCode::InvalidArgument,
                "timestamp " + std::to_string(timestamp_us) + " us is not after the previous frame's (" +
                    (prev ? std::to_string(prev->timestamp_us) : std::string()) + " us)");
        require(left->format == right->format, ErrorCode::InvalidArgument,
                "left and right have different formats (" + std::to_string(left->format) + " and " +
                    std::to_string(right->format) + ")");

        auto frame = std::make_shared<Frame>();
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

        // A stream's first frame: what its pair will need of it alone is computed now, while the
        // second frame is still to come. Failing here costs only that: the pair meets and reports
        // the same fault.
        lidarflow::pipeline::StreamCache first;
        const bool prepared = !prev && !estimator->pool && prepare_first_frame(*estimator, *frame, first);

        std::unique_ptr<Result> result;
        std::exception_ptr failed;   // frames in flight: the pair handed over failed
        if (prev && estimator->pool) {
            // The new pair runs beside the older ones while the oldest is waited for. Its prior
            // is that of the pair capacity() before it, handed over by now (deterministic).
            const int lag = static_cast<int>(estimator->pool->capacity());
            const int64_t index = estimator->pairs_started;
            estimator->pool->submit(pair_job(estimator, prev_frame, frame, rectify_seconds, index, lag,
                                             lagged_prior(*estimator, index, lag, prev->timestamp_us)));
            ++estimator->pairs_started;
            if (estimator->pool->full()) result = take_oldest_pair(*estimator, &failed);
        } else if (prev) {
            result = compute_pair(*estimator, *prev, *frame, &estimator->stream, rectify_seconds);
        }
        // Commit: nothing below can throw. In flight, a push that hands nothing over (the first
        // N - 1 after a flush) leaves no result, so lf_has_result says whether this one did.
        if (result || (prev && estimator->pool)) {
            estimator->result = std::move(result);
            estimator->pair_error = failed;
        }
        if (prepared) estimator->stream = std::move(first);
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
        if (estimator->pool) estimator->pool->drain();
        estimator->pairs_started = 0;
        estimator->priors.clear();
        estimator->previous.reset();
        estimator->result.reset();
        estimator->pair_error = nullptr;
        estimator->stream.clear();
        return static_cast<int32_t>(LF_OK);
    });
}

LF_API int32_t lf_flush(lf_estimator_t *estimator) {
    return guarded(sink_of(estimator), "lf_flush", [&] {
        require_non_null(estimator, "estimator");
        const BusyScope busy(estimator, "lf_flush");
        require(estimator->pool && estimator->pool->in_flight() > 0, ErrorCode::NotReady,
                "no pair in flight (with frames_in_flight 1 every push computes its pair)");
        std::exception_ptr failed;
        estimator->result = take_oldest_pair(*estimator, &failed);
        estimator->pair_error = failed;
        return static_cast<int32_t>(LF_OK);
    });
}

// From one of the handle's frame workers (its log callback) the handle's state belongs to the
// owner's thread: no result, and the worker thread's own message.
LF_API int32_t lf_has_result(const lf_estimator_t *estimator) {
    return estimator && pair_owner != estimator && estimator->result ? 1 : 0;
}

LF_API const char *lf_last_error(const lf_estimator_t *estimator) {
    return estimator && pair_owner != estimator ? estimator->error.c_str() : thread_last_error().c_str();
}

}  // extern "C"
