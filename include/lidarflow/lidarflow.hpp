// SPDX-License-Identifier: MIT
//
// lidarflow — C++17 API, header-only, over the stable C ABI of lidarflow.h.
//
// Nothing here is compiled into liblidarflow.so: every function below is inline and calls only
// the lf_* functions of lidarflow.h, so a program built with this header links against the same
// library, SONAME and CMake target / pkg-config file as a C program (lidarflow::lidarflow,
// `pkg-config --cflags --libs lidarflow`). The C++ standard library types used here never cross
// the library boundary, so any C++17 compiler and standard library work with any build of the
// library.
//
// Conventions
//  - Errors are exceptions: every failing lf_* call throws lidarflow::Error (a
//    std::runtime_error) that carries the lf_status_t value (status()) and a copy of the
//    library's last-error message (what()). Checks done by this header before the C ABI is
//    called (e.g. a cv::Mat of an unsupported type) throw the same Error with
//    LF_ERR_INVALID_ARGUMENT or LF_ERR_SIZE_MISMATCH. Out of memory in the library is
//    Error(LF_ERR_OUT_OF_MEMORY); allocations of this header throw std::bad_alloc. As in the C
//    ABI, a call that throws leaves its object unchanged and usable.
//  - Handles are RAII: Options and Estimator own their lf_* handle, are movable but not
//    copyable, and free it in their destructor. A moved-from object holds no handle: the
//    destructor, move assignment, get() and release() (null), and Estimator::has_result()
//    (false) work on it; everything else throws Error(LF_ERR_INVALID_ARGUMENT).
//  - Results are copies that the caller owns (std::vector, or cv::Mat with OpenCV): they stay
//    valid after the estimator moves on or is destroyed. Only ResultViews borrows (see there).
//  - Invalid values are NaN: where the latest result is not valid (sparse stages, see
//    lf_result_buffers_t), u, v, d0 and d1 are NaN in every copy this header returns, as the C
//    ABI gives them (the 0.1.0 library wrote 0 there; this header turns that into NaN too);
//    confidence is 0 there, as in the C ABI; 3-D points and motion are NaN there (as in the C
//    ABI). Raw borrowed views (ResultViews) show the C ABI's values. docs/CONVENTIONS.md.
//  - Thread safety, as in lidarflow.h: distinct objects may be used concurrently; one Options or
//    Estimator must not be used by two threads at the same time — this includes the member
//    functions that only read (has_result() excepted, see there), because every C ABI call
//    records its last error in the handle. Those readers are therefore not const. Free
//    functions, Error, Calibration, ImageView, LidarView and the result copies are plain values:
//    thread-safe to use from several threads as long as none modifies them.
//
// OpenCV (optional). With OpenCV the header also takes cv::Mat images (8-bit gray CV_8UC1 or
// BGR CV_8UC3, any stride, e.g. an ROI) and returns cv::Mat results: flow CV_32FC2 (u, v, the
// layout of cv::writeOpticalFlow / cv::readOpticalFlow), disparities and confidence CV_32F,
// masks CV_8U (255 valid / 0 not), 3-D points and motion CV_32FC3 — NaN where not valid.
// Only OpenCV's core module is used (link opencv_core).
//   LIDARFLOW_USE_OPENCV undefined: on when <opencv2/core.hpp> is on the include path
//                                   (__has_include), else off.
//   LIDARFLOW_USE_OPENCV 1:         on; an error if OpenCV's headers are missing.
//   LIDARFLOW_USE_OPENCV 0:         off, even where OpenCV is present.
// Define it (or not) the same way in every translation unit of a program.
//
// Typical use (see examples/cpp/lidarflow_flow.cpp):
//    lidarflow::Options opt = lidarflow::Options::preset("fast");
//    opt.set("threads", 4);
//    lidarflow::Estimator est(lidarflow::Calibration::read_kitti(cam_to_cam, velo_to_cam), opt);
//    // left0 ... right1: cv::Mat (8-bit gray or BGR); scan0: N x 4 CV_32F KITTI Velodyne records
//    est.push(0, left0, right0, lidarflow::LidarView::from_mat(lidarflow::LidarKind::points_lidar, scan0));
//    est.push(100000, left1, right1);
//    cv::Mat flow = est.flow();            // CV_32FC2
//    cv::writeOpticalFlow("flow.flo", flow);
#ifndef LIDARFLOW_HPP
#define LIDARFLOW_HPP

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

// lidarflow.h is C: its inline helpers use C casts, which C++ warnings such as -Wold-style-cast
// would report in every program that includes this header.
#if defined(__GNUC__)
#  pragma GCC diagnostic push
#  pragma GCC diagnostic ignored "-Wold-style-cast"
#endif
#include "lidarflow/lidarflow.h"
#if defined(__GNUC__)
#  pragma GCC diagnostic pop
#endif

#if !defined(LIDARFLOW_USE_OPENCV)
#  if defined(__has_include)
#    if __has_include(<opencv2/core.hpp>)
#      define LIDARFLOW_USE_OPENCV 1
#    else
#      define LIDARFLOW_USE_OPENCV 0
#    endif
#  else
#    define LIDARFLOW_USE_OPENCV 0
#  endif
#endif
#if LIDARFLOW_USE_OPENCV
#  include <opencv2/core.hpp>
#endif

namespace lidarflow {

// =============================================================================================
// Errors and version
// =============================================================================================

// The exception of every failing call. Thread-safe value type (copies share nothing with the
// library: the message is copied when the error is thrown).
class Error : public std::runtime_error {
public:
    // status: an lf_status_t value; message: what() (when empty, lf_status_string(status)).
    Error(int32_t status, const std::string &message)
        : std::runtime_error(message.empty() ? std::string(lf_status_string(status)) : message),
          status_(status) {}
    // The lf_status_t value (never LF_OK).
    int32_t status() const noexcept { return status_; }
    // Static English name of status(), e.g. "invalid argument"; never null.
    const char *status_string() const noexcept { return lf_status_string(status_); }

private:
    int32_t status_;
};

namespace detail {

// Throws Error(status, last_error()) unless status is LF_OK. last_error is a callable returning
// the C ABI's last-error string of the failed call; it is called (and the string copied) only
// after the call, on failure (a plain argument could be evaluated before the call).
template <typename LastError>
inline void check(int32_t status, LastError &&last_error) {
    if (status == LF_OK) return;
    const char *message = last_error();
    throw Error(status, message != nullptr ? std::string(message) : std::string());
}

inline void require(bool condition, int32_t status, const std::string &message) {
    if (!condition) throw Error(status, message);
}

constexpr float nan_value() noexcept { return std::numeric_limits<float>::quiet_NaN(); }

#if LIDARFLOW_USE_OPENCV
// A new Mat of `type` holding a copy of `values` (height x width x channels, row-major).
template <typename T>
cv::Mat copy_to_mat(const std::vector<T> &values, uint32_t width, uint32_t height, int type, const char *what) {
    const std::size_t n = std::size_t{width} * height * static_cast<std::size_t>(CV_MAT_CN(type));
    require(values.size() == n && n > 0, LF_ERR_INVALID_ARGUMENT,
            std::string("lidarflow: the result holds no ") + what + " plane (not asked for)");
    return cv::Mat(static_cast<int>(height), static_cast<int>(width), type, const_cast<T *>(values.data())).clone();
}
#endif

}  // namespace detail

// Receives the library's messages: level (lf_log_level_t: LF_LOG_DEBUG ... LF_LOG_ERROR) and the
// text (naming the estimator handle and frame; a copy the handler may keep).
using LogHandler = std::function<void(int level, const std::string &message)>;

namespace detail {
struct LogSlot {
    std::mutex mutex;
    std::unique_ptr<LogHandler> handler;
};
inline LogSlot &log_slot() {
    static LogSlot slot;
    return slot;
}
// How many handler calls run on this thread (set_log_handler refuses to run inside one).
inline int &handler_depth() noexcept {
    static thread_local int depth = 0;
    return depth;
}
inline void log_trampoline(int32_t level, const char *message, void *user) noexcept {
    ++handler_depth();
    try {
        (*static_cast<LogHandler *>(user))(level, std::string(message));
    } catch (...) {
        // An exception must not unwind through the library: the message is lost, the frame goes on.
    }
    --handler_depth();
}
}  // namespace detail

// Sends the library's messages of level >= min_level to `handler`, process-wide (lf_set_log_callback);
// an empty handler silences them (the default). The handler runs on any thread that runs a
// library call, concurrently from several, and its exceptions are swallowed. When this returns
// the previous handler is not running any more and has been destroyed. Thread-safe. Throws
// Error(LF_ERR_INVALID_ARGUMENT) for min_level outside [LF_LOG_DEBUG, LF_LOG_ERROR], and
// Error(LF_ERR_BAD_STATE) when called from inside a handler (it would destroy the handler that
// is running); the previous handler then stays.
inline void set_log_handler(LogHandler handler, int min_level = LF_LOG_INFO) {
    detail::require(detail::handler_depth() == 0, LF_ERR_BAD_STATE,
                    "lidarflow::set_log_handler: called from inside a log handler, which it would destroy");
    std::unique_ptr<LogHandler> next = handler ? std::make_unique<LogHandler>(std::move(handler)) : nullptr;
    detail::LogSlot &slot = detail::log_slot();
    const std::lock_guard<std::mutex> lock(slot.mutex);
    detail::check(lf_set_log_callback(next ? &detail::log_trampoline : nullptr, min_level, next.get()),
                  [] { return lf_last_error(nullptr); });
    slot.handler = std::move(next);  // the old handler: no call of it runs any more
}

// Run-time version of the loaded library (lf_version_string / lf_version_number / lf_abi_major).
// Compare with LF_VERSION_STRING / LF_VERSION_NUMBER / LF_ABI_MAJOR of the headers. Thread-safe.
inline std::string version_string() { return lf_version_string(); }
inline uint32_t version_number() noexcept { return lf_version_number(); }
inline uint32_t abi_major() noexcept { return lf_abi_major(); }

// Static English description of an lf_status_t value ("unknown status" for others).
// Thread-safe.
inline const char *status_string(int32_t status) noexcept { return lf_status_string(status); }

// =============================================================================================
// Options
// =============================================================================================

// Owns an lf_options_t: the estimator settings by key, exactly the keys, types, ranges and
// defaults documented in lidarflow.h ("threads", "preset", "use_lidar", "matching.grid_step",
// ...). An Estimator copies its options when it is created; the Options may then change or go
// away without affecting it. Movable, not copyable. One thread at a time per object (getters
// included: the C ABI records their last error in the object).
class Options {
public:
    // The defaults. Throws Error (LF_ERR_OUT_OF_MEMORY).
    Options() {
        lf_options_t *o = nullptr;
        detail::check(lf_options_create(&o), [] { return lf_last_error(nullptr); });
        handle_ = o;
    }
    // The defaults, then the preset `name` ("default", "balanced", "fast" or "realtime"; see
    // "preset" in lidarflow.h). Throws Error (LF_ERR_INVALID_ARGUMENT for an unknown preset).
    static Options preset(const std::string &name) {
        Options o;
        o.set_string("preset", name);
        return o;
    }

    Options(Options &&other) noexcept : handle_(std::exchange(other.handle_, nullptr)) {}
    Options &operator=(Options &&other) noexcept {
        if (this != &other) {
            lf_options_destroy(handle_);
            handle_ = std::exchange(other.handle_, nullptr);
        }
        return *this;
    }
    Options(const Options &) = delete;
    Options &operator=(const Options &) = delete;
    ~Options() { lf_options_destroy(handle_); }

    // Sets `key` to `value`, chosen by the value's C++ type: bool -> 0/1 (switches), integers
    // -> lf_options_set_int (integer, switch and float keys), float/double ->
    // lf_options_set_float, strings (std::string, std::string_view, const char *) ->
    // lf_options_set_string. Returns *this, so calls chain: opt.set("threads", 4).set(...).
    // Throws Error(LF_ERR_INVALID_ARGUMENT) for an unknown key, a value of the wrong type,
    // NaN/inf or a value out of bounds (the message names the key and the accepted range);
    // the options are then unchanged. "preset" resets every key except "threads": set it first.
    template <typename T>
    Options &set(const std::string &key, const T &value) {
        if constexpr (std::is_same_v<T, bool>) {
            return set_int(key, value ? 1 : 0);
        } else if constexpr (std::is_integral_v<T>) {
            // Values beyond int64_t are out of every key's range; saturate to keep the error.
            if constexpr (std::is_unsigned_v<T> && sizeof(T) >= sizeof(int64_t)) {
                return set_int(key, value > static_cast<T>(INT64_MAX) ? INT64_MAX : static_cast<int64_t>(value));
            } else {
                return set_int(key, static_cast<int64_t>(value));
            }
        } else if constexpr (std::is_floating_point_v<T>) {
            return set_float(key, static_cast<double>(value));
        } else if constexpr (std::is_convertible_v<const T &, const char *>) {
            const char *text = value;
            detail::require(text != nullptr, LF_ERR_INVALID_ARGUMENT,
                            "lidarflow: Options::set: null string for option '" + key + "'");
            return set_string(key, text);
        } else {
            static_assert(std::is_constructible_v<std::string, const T &>,
                          "Options::set takes bool, integers, floating point or strings");
            return set_string(key, std::string(value));
        }
    }
    // The typed setters behind set(): lf_options_set_int / _float / _string. Same errors, and
    // LF_ERR_INVALID_ARGUMENT for a key or string value with an embedded NUL (C would cut it).
    Options &set_int(const std::string &key, int64_t value) {
        check(lf_options_set_int(handle_, c_text(key, "key"), value));
        return *this;
    }
    Options &set_float(const std::string &key, double value) {
        check(lf_options_set_float(handle_, c_text(key, "key"), value));
        return *this;
    }
    Options &set_string(const std::string &key, const std::string &value) {
        check(lf_options_set_string(handle_, c_text(key, "key"), c_text(value, "value")));
        return *this;
    }

    // Current value of an integer or switch key (lf_options_get_int). Throws Error
    // (LF_ERR_INVALID_ARGUMENT: unknown key, or not an integer key).
    int64_t get_int(const std::string &key) {
        int64_t v = 0;
        check(lf_options_get_int(handle_, key.c_str(), &v));
        return v;
    }
    // Current value of any numeric key (lf_options_get_float). Throws as get_int.
    double get_float(const std::string &key) {
        double v = 0;
        check(lf_options_get_float(handle_, key.c_str(), &v));
        return v;
    }
    // Current value of a string key, copied (lf_options_get_string). Throws as get_int.
    std::string get_string(const std::string &key) {
        const char *v = nullptr;
        check(lf_options_get_string(handle_, key.c_str(), &v));
        return v != nullptr ? std::string(v) : std::string();
    }

    // The owned handle, for C ABI calls; still owned by this object (null after a move).
    lf_options_t *get() const noexcept { return handle_; }
    // Gives up ownership: the caller frees the returned handle with lf_options_destroy().
    lf_options_t *release() noexcept { return std::exchange(handle_, nullptr); }

private:
    static const char *c_text(const std::string &s, const char *what) {
        detail::require(s.find('\0') == std::string::npos, LF_ERR_INVALID_ARGUMENT,
                        std::string("lidarflow: Options::set: the ") + what + " holds a NUL character");
        return s.c_str();
    }
    // Throws Error with this object's last-error message unless status is LF_OK.
    void check(int32_t status) {
        detail::check(status, [this] { return lf_options_last_error(handle_); });
    }

    lf_options_t *handle_ = nullptr;
};

// =============================================================================================
// Calibration and inputs
// =============================================================================================

// The stereo camera (lf_calibration_t): the rectified pair, lengths in metres, pixel quantities in pixels
// of the full-resolution images; ranges as in lidarflow.h (checked when an Estimator is
// created). A plain value.
struct Calibration {
    double fx = 0, fy = 0;  // focal lengths [px]
    double cx = 0, cy = 0;  // principal point [px]
    double baseline = 0;    // distance of the rectified left and right centres [m]
    // Row-major 4x4 rigid transform LiDAR frame -> left rectified camera frame (x right, y down,
    // z forward), last row 0 0 0 1; only used when has_lidar_to_camera (needed by
    // LidarView::points_lidar).
    bool has_lidar_to_camera = false;
    std::array<double, 16> lidar_to_camera{};
    // Size of the images the calibration is for [px]; 0 = unknown. Another size is warned about
    // once per Estimator, or refused with the option "input.strict".
    uint32_t image_width = 0, image_height = 0;
    // A raw rig (lf_raw_camera_t, row-major K, D, R, P per camera): the Estimator rectifies each
    // pair, and fx ... baseline describe the rectified left camera, which results are in.
    struct RawCamera {
        std::array<double, 9> K{};
        std::array<double, 8> D{};
        std::array<double, 9> R{};
        std::array<double, 12> P{};
    };
    bool rectify = false;
    RawCamera raw_left, raw_right;

    // A pinhole pair without LiDAR extrinsics.
    static Calibration pinhole(double fx, double fy, double cx, double cy, double baseline) {
        Calibration c;
        c.fx = fx;
        c.fy = fy;
        c.cx = cx;
        c.cy = cy;
        c.baseline = baseline;
        return c;
    }

    // Reads KITTI calibration files (lf_read_kitti_calibration): the camera from
    // calib_cam_to_cam.txt and, unless velo_to_cam_path is empty, lidar_to_camera from
    // calib_velo_to_cam.txt. Throws Error (LF_ERR_IO, LF_ERR_FORMAT). Thread-safe.
    static Calibration read_kitti(const std::string &cam_to_cam_path, const std::string &velo_to_cam_path = {}) {
        return read_with(lf_read_kitti_calibration, cam_to_cam_path, velo_to_cam_path);
    }

    // Reads any calibration source (lf_read_calibration): a KITTI calib_cam_to_cam.txt, an OpenCV
    // stereo calibration file or "LEFT,RIGHT" camera_info YAMLs, plus optionally a
    // calib_velo_to_cam.txt into the raw left camera. Throws Error (LF_ERR_IO, LF_ERR_FORMAT).
    // Thread-safe.
    static Calibration read(const std::string &calibration, const std::string &velo_to_cam_path = {}) {
        return read_with(lf_read_calibration, calibration, velo_to_cam_path);
    }

    // Conversions to and from the C struct (struct_size set).
    lf_calibration_t to_c() const noexcept {
        lf_calibration_t c;
        lf_calibration_init(&c);
        c.fx = fx;
        c.fy = fy;
        c.cx = cx;
        c.cy = cy;
        c.baseline = baseline;
        c.has_lidar_to_camera = has_lidar_to_camera ? 1u : 0u;
        for (std::size_t i = 0; i < 16; ++i) c.lidar_to_camera[i] = lidar_to_camera[i];
        c.image_width = image_width;
        c.image_height = image_height;
        c.rectify = rectify ? 1u : 0u;
        copy_raw(raw_left, c.raw_left);
        copy_raw(raw_right, c.raw_right);
        return c;
    }
    static Calibration from_c(const lf_calibration_t &c) noexcept {
        Calibration r = pinhole(c.fx, c.fy, c.cx, c.cy, c.baseline);
        r.has_lidar_to_camera = c.has_lidar_to_camera != 0;
        for (std::size_t i = 0; i < 16; ++i) r.lidar_to_camera[i] = c.lidar_to_camera[i];
        r.image_width = c.image_width;
        r.image_height = c.image_height;
        r.rectify = c.rectify != 0;
        copy_raw(c.raw_left, r.raw_left);
        copy_raw(c.raw_right, r.raw_right);
        return r;
    }

private:
    static Calibration read_with(int32_t (*reader)(const char *, const char *, lf_calibration_t *),
                                 const std::string &calibration, const std::string &velo_to_cam_path) {
        lf_calibration_t c;
        lf_calibration_init(&c);
        detail::check(reader(calibration.c_str(), velo_to_cam_path.empty() ? nullptr : velo_to_cam_path.c_str(), &c),
                      [] { return lf_last_error(nullptr); });
        return from_c(c);
    }

    // RawCamera <-> lf_raw_camera_t (same field names and lengths).
    template <class From, class To>
    static void copy_raw(const From &from, To &to) noexcept {
        for (std::size_t i = 0; i < 9; ++i) to.K[i] = from.K[i];
        for (std::size_t i = 0; i < 8; ++i) to.D[i] = from.D[i];
        for (std::size_t i = 0; i < 9; ++i) to.R[i] = from.R[i];
        for (std::size_t i = 0; i < 12; ++i) to.P[i] = from.P[i];
    }
};

// Pixel formats (lf_pixel_format_t).
enum class PixelFormat : int32_t { gray8 = LF_PIXEL_GRAY8, rgb8 = LF_PIXEL_RGB8, bgr8 = LF_PIXEL_BGR8 };

// A borrowed, read-only 8-bit image (lf_image_t): the caller keeps ownership of the pixels,
// which need only stay valid and unchanged during the Estimator::push that reads them (the
// library copies them). Rows are stride_bytes apart (0 = packed: width * bytes per pixel).
struct ImageView {
    const void *data = nullptr;
    uint32_t width = 0, height = 0;
    uint64_t stride_bytes = 0;
    PixelFormat format = PixelFormat::gray8;

    static ImageView gray8(const void *data, uint32_t width, uint32_t height, uint64_t stride_bytes = 0) {
        return {data, width, height, stride_bytes, PixelFormat::gray8};
    }
    static ImageView rgb8(const void *data, uint32_t width, uint32_t height, uint64_t stride_bytes = 0) {
        return {data, width, height, stride_bytes, PixelFormat::rgb8};
    }
    static ImageView bgr8(const void *data, uint32_t width, uint32_t height, uint64_t stride_bytes = 0) {
        return {data, width, height, stride_bytes, PixelFormat::bgr8};
    }
#if LIDARFLOW_USE_OPENCV
    // A view of `image`: CV_8UC1 (gray) or CV_8UC3 (BGR, OpenCV's order), 2-D, any stride (an
    // ROI or a submatrix works, no copy). The Mat keeps ownership; keep it alive and unchanged
    // until the push returns. Throws Error(LF_ERR_INVALID_ARGUMENT) for an empty Mat, more than 2
    // dimensions or another type (convert 16-bit or 4-channel images first, e.g. with
    // convertTo / cvtColor).
    static ImageView from_mat(const cv::Mat &image) {
        detail::require(!image.empty() && image.dims == 2, LF_ERR_INVALID_ARGUMENT,
                        "lidarflow: an image must be a non-empty 2-D cv::Mat");
        detail::require(image.type() == CV_8UC1 || image.type() == CV_8UC3, LF_ERR_INVALID_ARGUMENT,
                        "lidarflow: an image must be 8-bit gray (CV_8UC1) or BGR (CV_8UC3), not " +
                            cv::typeToString(image.type()));
        return {image.data, static_cast<uint32_t>(image.cols), static_cast<uint32_t>(image.rows),
                static_cast<uint64_t>(image.step[0]), image.channels() == 1 ? PixelFormat::gray8 : PixelFormat::bgr8};
    }
#endif

    lf_image_t to_c() const noexcept {
        const uint64_t bpp = format == PixelFormat::gray8 ? 1u : 3u;
        return {data, width, height, stride_bytes != 0 ? stride_bytes : uint64_t{width} * bpp,
                static_cast<int32_t>(format)};
    }
};

// Kinds of LiDAR input (lf_lidar_kind_t).
enum class LidarKind : int32_t {
    none = LF_LIDAR_NONE,
    points_camera = LF_LIDAR_POINTS_CAMERA,  // float (x, y, z) [m], left rectified camera frame
    points_lidar = LF_LIDAR_POINTS_LIDAR,    // float (x, y, z) [m], LiDAR frame (needs lidar_to_camera)
    disparity = LF_LIDAR_DISPARITY           // float (column, row, disparity [px])
};

// A borrowed list of `count` LiDAR entries (lf_lidar_t): three floats at the start of each
// element, elements stride_bytes apart (0 = packed, 12 bytes; 16 for KITTI's x, y, z,
// reflectance records). Semantics of each kind, and what is dropped, as in lidarflow.h. The
// caller keeps ownership; the data need only stay valid during the push that reads it.
struct LidarView {
    LidarKind kind = LidarKind::none;
    const void *data = nullptr;
    uint32_t count = 0;
    uint64_t stride_bytes = 0;

    static LidarView points_camera(const float *xyz, std::size_t count, uint64_t stride_bytes = 0) {
        return make(LidarKind::points_camera, xyz, count, stride_bytes);
    }
    static LidarView points_lidar(const float *xyz, std::size_t count, uint64_t stride_bytes = 0) {
        return make(LidarKind::points_lidar, xyz, count, stride_bytes);
    }
    static LidarView disparities(const float *xyd, std::size_t count, uint64_t stride_bytes = 0) {
        return make(LidarKind::disparity, xyd, count, stride_bytes);
    }
    // A list of `kind` entries: every 3 floats of `values` are one entry (its size must be a
    // multiple of 3). The vector keeps ownership.
    static LidarView from_vector(LidarKind kind, const std::vector<float> &values) {
        detail::require(values.size() % 3 == 0, LF_ERR_SIZE_MISMATCH,
                        "lidarflow: a LiDAR vector holds 3 floats per entry; its size is not a multiple of 3");
        return make(kind, values.data(), values.size() / 3, 0);
    }
#if LIDARFLOW_USE_OPENCV
    // A list of `kind` entries, one per row of `points`: CV_32FC1 with 3 or 4 columns (x, y, z
    // and e.g. KITTI's reflectance; a wider record: pass colRange(0, 3)) or one column of
    // CV_32FC3 / CV_32FC4; any row stride. Throws Error(LF_ERR_INVALID_ARGUMENT) for another
    // layout (a 3 x N Mat of N points is one: transpose it). An empty Mat is an empty list.
    static LidarView from_mat(LidarKind kind, const cv::Mat &points) {
        if (points.empty()) return make(kind, nullptr, 0, 0);
        const bool rows_of_floats = points.dims == 2 && points.depth() == CV_32F &&
                                    ((points.channels() == 1 && (points.cols == 3 || points.cols == 4)) ||
                                     (points.cols == 1 && (points.channels() == 3 || points.channels() == 4)));
        detail::require(rows_of_floats, LF_ERR_INVALID_ARGUMENT,
                        "lidarflow: LiDAR points must be one per row: a CV_32FC1 Mat of 3 or 4 columns or one "
                        "CV_32FC3/CV_32FC4 column, not " + cv::typeToString(points.type()) + " of " +
                            std::to_string(points.rows) + "x" + std::to_string(points.cols));
        return make(kind, points.data, static_cast<std::size_t>(points.rows), static_cast<uint64_t>(points.step[0]));
    }
#endif

    lf_lidar_t to_c() const noexcept { return {static_cast<int32_t>(kind), count, data, stride_bytes}; }

private:
    static LidarView make(LidarKind kind, const void *data, std::size_t count, uint64_t stride_bytes) {
        detail::require(count <= UINT32_MAX, LF_ERR_INVALID_ARGUMENT, "lidarflow: more than 2^32 - 1 LiDAR entries");
        return {kind, data, static_cast<uint32_t>(count), stride_bytes};
    }
};

// =============================================================================================
// Results
// =============================================================================================

// Stages (lf_stage_t), as reported by ResultInfo::last_stage.
enum class Stage : int32_t {
    matching = LF_STAGE_MATCHING,
    consistency = LF_STAGE_CONSISTENCY,
    sparse = LF_STAGE_SPARSE,
    interpolation = LF_STAGE_INTERPOLATION
};

// Wall time of one stage of a result (lf_get_timing); name copied.
struct Timing {
    std::string name;  // e.g. "matching_forward", "interpolation"
    double seconds = 0;
};

// Facts about a result (lf_result_info_t), plus its per-stage timings, copied.
struct ResultInfo {
    uint32_t width = 0, height = 0;  // size of the result (= the images')
    Stage last_stage = Stage::interpolation;
    int64_t t0_us = 0, t1_us = 0;    // timestamps of the reference (t0) and second (t1) frame
    double total_seconds = 0;        // wall time of the computation
    bool rectified = false;          // the pair was rectified inside: results in the rectified left camera
    std::vector<Timing> timings;     // in execution order
};

// A copy of the latest result, owned by the caller. Every plane holds width * height values,
// row-major (index y * width + x), in the left image at t0:
//   u, v   optical flow to the left image at t1 [px]; d0 disparity at t0, d1 disparity of the
//          same point at t1 [px] — NaN where not valid
//   valid  1 where (u, v, d0, d1) is defined, else 0 (the dense result is valid everywhere;
//          the stages before interpolation are sparse)
//   confidence  >= 0, larger is better, 0 where not valid
// Planes that were not asked for are empty.
struct Result {
    ResultInfo info;
    std::vector<float> u, v, d0, d1, confidence;
    std::vector<uint8_t> valid;

    uint32_t width() const noexcept { return info.width; }
    uint32_t height() const noexcept { return info.height; }
    std::size_t index(uint32_t x, uint32_t y) const noexcept { return std::size_t{y} * info.width + x; }

#if LIDARFLOW_USE_OPENCV
    // New cv::Mat copies of the planes, owned by the caller (NaN as above). Throw
    // Error(LF_ERR_INVALID_ARGUMENT) when the plane was not copied into this Result.
    //   flow_mat()        CV_32FC2 (u, v) [px]: OpenCV's optical-flow layout, as read and
    //                     written by cv::readOpticalFlow / cv::writeOpticalFlow
    //   disparity0_mat()  CV_32F d0 [px];  disparity1_mat(): CV_32F d1 [px]
    //   confidence_mat()  CV_32F, 0 where not valid
    //   valid_mask()      CV_8U, 255 where valid, 0 elsewhere (an OpenCV mask)
    cv::Mat flow_mat() const {
        detail::require(!u.empty() && u.size() == v.size(), LF_ERR_INVALID_ARGUMENT,
                        "lidarflow: the result holds no u and v planes (not asked for)");
        std::vector<float> uv(2 * u.size());
        for (std::size_t i = 0; i < u.size(); ++i) {
            uv[2 * i] = u[i];
            uv[2 * i + 1] = v[i];
        }
        return detail::copy_to_mat(uv, info.width, info.height, CV_32FC2, "u and v");
    }
    cv::Mat disparity0_mat() const { return detail::copy_to_mat(d0, info.width, info.height, CV_32FC1, "d0"); }
    cv::Mat disparity1_mat() const { return detail::copy_to_mat(d1, info.width, info.height, CV_32FC1, "d1"); }
    cv::Mat confidence_mat() const {
        return detail::copy_to_mat(confidence, info.width, info.height, CV_32FC1, "confidence");
    }
    cv::Mat valid_mask() const {
        cv::Mat m = detail::copy_to_mat(valid, info.width, info.height, CV_8UC1, "valid");
        m.setTo(255, m);
        return m;
    }
#endif
};

// 3-D copy of the latest result (lf_get_points3d), owned by the caller; width * height entries,
// row-major, three floats per pixel for points and motion:
//   points (x, y, z) [m] seen at the pixel at t0, left camera frame at t0;
//   motion (dx, dy, dz) [m]: its position at t1 (camera frame at t1) minus at t0 — scene flow
//          relative to the camera, ego-motion included;
//   valid  1 where the result is valid with d0 > 0 and d1 > 0 (and the values fit a float);
//          elsewhere points and motion are NaN.
struct Points3d {
    uint32_t width = 0, height = 0;
    std::vector<float> points, motion;
    std::vector<uint8_t> valid;

#if LIDARFLOW_USE_OPENCV
    // New CV_32FC3 copies owned by the caller (NaN where not valid), and valid as an OpenCV
    // mask (CV_8U, 255 / 0).
    cv::Mat points_mat() const { return detail::copy_to_mat(points, width, height, CV_32FC3, "points"); }
    cv::Mat motion_mat() const { return detail::copy_to_mat(motion, width, height, CV_32FC3, "motion"); }
    cv::Mat valid_mask() const {
        cv::Mat m = detail::copy_to_mat(valid, width, height, CV_8UC1, "valid");
        m.setTo(255, m);
        return m;
    }
#endif
};

// The static scene's rigid motion t0 -> t1 (lf_get_ego_motion): transform T, row-major 4x4,
// maps a static point's coordinates in the left camera frame at t0 to those at t1
// (X1 = T [X0; 1], metres); the camera's own motion is T^-1. inliers / candidates: the matches
// the fit explained / saw.
struct EgoMotion {
    std::array<double, 16> transform{};
    uint32_t inliers = 0, candidates = 0;

#if LIDARFLOW_USE_OPENCV
    cv::Matx44d matx() const { return cv::Matx44d(transform.data()); }
#endif
};

// The input quality of the latest result (lf_get_quality): flags are lf_quality_flag_t bits
// (0 = ok), reason one English clause per flag ("" when ok); docs/CONVENTIONS.md says what each
// means and what to do.
struct Quality {
    uint32_t flags = 0;
    std::string reason;

    bool ok() const { return flags == 0; }
    bool has(lf_quality_flag_t f) const { return (flags & static_cast<uint32_t>(f)) != 0; }
    // The names of the set flags ("left_right_swapped", ...), in bit order; empty when ok.
    std::vector<std::string> names() const {
        std::vector<std::string> n;
        for (uint32_t bit = 1; bit != 0 && bit <= flags; bit <<= 1)
            if (flags & bit) n.emplace_back(lf_quality_name(bit));
        return n;
    }
};

// Object motion of the latest result (lf_get_object_motion), owned by the caller; width * height
// entries, row-major: motion (mx, my, mz) [m] = X1 - T X0 (scene flow without the camera's
// motion, left camera frame at t1; about 0 on the static world), valid as Points3d::valid where
// the object motion fits a float (elsewhere motion is NaN).
struct ObjectMotion {
    uint32_t width = 0, height = 0;
    std::vector<float> motion;
    std::vector<uint8_t> valid;

#if LIDARFLOW_USE_OPENCV
    // A new CV_32FC3 copy owned by the caller, NaN where not valid.
    cv::Mat motion_mat() const { return detail::copy_to_mat(motion, width, height, CV_32FC3, "motion"); }
#endif
};

// Borrowed, read-only views into the estimator's latest result (lf_get_result_views): no copy,
// the C ABI's values (NaN where not valid; 0 from a 0.1.0 library). Valid until the next push,
// flush, reset, or the destruction of the Estimator (a push that throws keeps them valid); read them
// only while no other thread calls into that Estimator. Rows are stride_bytes apart.
struct ResultViews {
    uint32_t width = 0, height = 0;
    lf_view_t u{}, v{}, d0{}, d1{}, valid{}, confidence{};

    // Value at (x, y) of a float32 plane (u, v, d0, d1, confidence) or of valid (uint8).
    static float at(const lf_view_t &plane, uint32_t x, uint32_t y) noexcept {
        return reinterpret_cast<const float *>(static_cast<const unsigned char *>(plane.data) +
                                               plane.stride_bytes * y)[x];
    }
    static uint8_t at_u8(const lf_view_t &plane, uint32_t x, uint32_t y) noexcept {
        return (static_cast<const uint8_t *>(plane.data) + plane.stride_bytes * y)[x];
    }
};

// =============================================================================================
// Estimator
// =============================================================================================

// Owns an lf_estimator_t: settings, the previous frame and the latest result. Push stereo frames
// in time order; from the second push on, each push computes (synchronously) the scene flow from
// the previous frame (t0, the reference) to the new one (t1) and replaces the result (with the
// option "frames_in_flight" N, pairs run N at a time and a push hands over the oldest once N
// are in flight, i.e. the pair N - 1 frames older; one that hands nothing over leaves no
// result: flush()). Movable, not copyable. One thread at a time per Estimator, readers included (they are not const for
// that reason); distinct Estimators may run concurrently, each from its own thread.
class Estimator {
public:
    // Creates an estimator for `calibration` with default options, or with `options` (copied:
    // the Options may change or be destroyed afterwards). Throws Error: LF_ERR_INVALID_ARGUMENT
    // (calibration outside the ranges of lidarflow.h, inconsistent options), LF_ERR_IO /
    // LF_ERR_FORMAT ("interpolation.sed_model"), LF_ERR_OUT_OF_MEMORY.
    explicit Estimator(const Calibration &calibration) { create(nullptr, calibration); }
    Estimator(const Calibration &calibration, const Options &options) {
        detail::require(options.get() != nullptr, LF_ERR_INVALID_ARGUMENT, "lidarflow: moved-from Options");
        create(options.get(), calibration);
    }

    Estimator(Estimator &&other) noexcept : handle_(std::exchange(other.handle_, nullptr)) {}
    Estimator &operator=(Estimator &&other) noexcept {
        if (this != &other) {
            lf_destroy(handle_);
            handle_ = std::exchange(other.handle_, nullptr);
        }
        return *this;
    }
    Estimator(const Estimator &) = delete;
    Estimator &operator=(const Estimator &) = delete;
    // Frees the estimator; ResultViews from it become invalid, copies stay valid.
    ~Estimator() { lf_destroy(handle_); }

    // Adds the next stereo frame (lf_push_frame), without LiDAR or with `lidar`. timestamp_us
    // must exceed the previous frame's. left and right: same size and format, fixed from the
    // first frame until reset(). Everything is copied before the call returns. Throws Error:
    // LF_ERR_INVALID_ARGUMENT (bad data, timestamp not increasing, LiDAR values out of range,
    // points_lidar without lidar_to_camera, untextured images, ...), LF_ERR_SIZE_MISMATCH (sizes
    // or format differ between the images or from the previous frame, strides too small),
    // LF_ERR_OUT_OF_MEMORY; the estimator is then unchanged (previous frame and result kept).
    void push(int64_t timestamp_us, const ImageView &left, const ImageView &right) {
        push_c(timestamp_us, left, right, nullptr);
    }
    void push(int64_t timestamp_us, const ImageView &left, const ImageView &right, const LidarView &lidar) {
        const lf_lidar_t l = lidar.to_c();
        push_c(timestamp_us, left, right, &l);
    }
#if LIDARFLOW_USE_OPENCV
    // The same with cv::Mat images (ImageView::from_mat: 8-bit gray or BGR, any stride).
    void push(int64_t timestamp_us, const cv::Mat &left, const cv::Mat &right) {
        push(timestamp_us, ImageView::from_mat(left), ImageView::from_mat(right));
    }
    void push(int64_t timestamp_us, const cv::Mat &left, const cv::Mat &right, const LidarView &lidar) {
        push(timestamp_us, ImageView::from_mat(left), ImageView::from_mat(right), lidar);
    }
#endif

    // With the option "frames_in_flight" > 1 (pushes hand results over late, in order): waits
    // for the oldest pair in flight and hands it over (lf_flush). Returns false when no pair was
    // in flight; true otherwise, then has_result() says whether it has a result (a failed pair
    // has none: the readers throw its error). At the end of a stream:
    //     while (est.flush()) if (est.has_result()) ... read the result ...
    // Throws Error(LF_ERR_BAD_STATE).
    bool flush() {
        const int32_t status = lf_flush(handle_);
        if (status == LF_ERR_NOT_READY) return false;
        detail::check(status, [this] { return lf_last_error(handle_); });
        return true;
    }

    // Forgets the previous frame and the result (lf_reset): the next push starts a new sequence,
    // of any size. ResultViews become invalid.
    void reset() { detail::check(lf_reset(handle_), [this] { return lf_last_error(handle_); }); }

    // True when a result is available (two frames pushed since creation or reset). Never throws;
    // false for a moved-from Estimator. Changes nothing in the handle, so (unlike the other
    // readers) it is const; still not concurrently with a push on the same Estimator.
    bool has_result() const noexcept { return lf_has_result(handle_) != 0; }

    // Facts and per-stage timings of the latest result. Throws Error(LF_ERR_NOT_READY) before
    // there is one.
    ResultInfo info() {
        lf_result_info_t i;
        lf_result_info_init(&i);
        detail::check(lf_get_result_info(handle_, &i), [this] { return lf_last_error(handle_); });
        ResultInfo r;
        r.width = i.width;
        r.height = i.height;
        r.last_stage = static_cast<Stage>(i.last_stage);
        r.t0_us = i.t0_us;
        r.t1_us = i.t1_us;
        r.total_seconds = i.total_seconds;
        r.rectified = i.rectified != 0;
        r.timings.reserve(i.timing_count);
        for (uint32_t k = 0; k < i.timing_count; ++k) {
            const char *name = nullptr;
            double seconds = 0;
            detail::check(lf_get_timing(handle_, k, &name, &seconds), [this] { return lf_last_error(handle_); });
            r.timings.push_back({name != nullptr ? std::string(name) : std::string(), seconds});
        }
        return r;
    }

    // What result() copies: a combination of these flags.
    enum Planes : unsigned {
        plane_u = 1u, plane_v = 2u, plane_d0 = 4u, plane_d1 = 8u, plane_valid = 16u, plane_confidence = 32u,
        planes_all = 63u
    };

    // A copy of the latest result (lf_get_result): the planes in `planes` (all by default),
    // with NaN in u, v, d0, d1 where not valid (see Result). Throws Error(LF_ERR_NOT_READY)
    // before there is a result.
    Result result(unsigned planes = planes_all) {
        Result r;
        r.info = info();
        const std::size_t n = std::size_t{r.info.width} * r.info.height;
        lf_result_buffers_t b;
        lf_result_buffers_init(&b);
        b.width = r.info.width;
        b.height = r.info.height;
        const uint64_t fstride = uint64_t{r.info.width} * sizeof(float);
        auto plane = [&](unsigned flag, std::vector<float> &dst, lf_plane_t &p) {
            if ((planes & flag) == 0) return;
            dst.assign(n, 0.0f);
            p = {dst.data(), fstride};
        };
        plane(plane_u, r.u, b.u);
        plane(plane_v, r.v, b.v);
        plane(plane_d0, r.d0, b.d0);
        plane(plane_d1, r.d1, b.d1);
        plane(plane_confidence, r.confidence, b.confidence);
        // valid is always fetched: it decides where the NaN go; dropped below if not asked for.
        r.valid.assign(n, 0);
        b.valid = {r.valid.data(), uint64_t{r.info.width}};
        detail::check(lf_get_result(handle_, &b), [this] { return lf_last_error(handle_); });
        for (std::vector<float> *p : {&r.u, &r.v, &r.d0, &r.d1}) {
            if (p->empty()) continue;
            for (std::size_t i = 0; i < n; ++i)
                if (r.valid[i] == 0) (*p)[i] = detail::nan_value();
        }
        if ((planes & plane_valid) == 0) std::vector<uint8_t>().swap(r.valid);
        return r;
    }

    // A copy of the latest result in 3-D (lf_get_points3d with the estimator's calibration; see
    // Points3d). Throws Error(LF_ERR_NOT_READY) before there is a result.
    Points3d points3d() {
        const ResultInfo i = info();
        Points3d r;
        r.width = i.width;
        r.height = i.height;
        const std::size_t n = std::size_t{i.width} * i.height;
        r.points.assign(3 * n, 0.0f);
        r.motion.assign(3 * n, 0.0f);
        r.valid.assign(n, 0);
        lf_points3d_buffers_t b;
        lf_points3d_buffers_init(&b);
        b.width = i.width;
        b.height = i.height;
        b.points = {r.points.data(), uint64_t{i.width} * 3 * sizeof(float)};
        b.motion = {r.motion.data(), uint64_t{i.width} * 3 * sizeof(float)};
        b.valid = {r.valid.data(), uint64_t{i.width}};
        detail::check(lf_get_points3d(handle_, &b), [this] { return lf_last_error(handle_); });
        return r;
    }

    // The latest result's ego-motion (see EgoMotion). Throws Error(LF_ERR_NOT_READY) before
    // there is a result, and Error(LF_ERR_BAD_STATE) when the result has none (the message
    // names the lf_ego_state_t reason: no stage 4, too few inliers, ...).
    EgoMotion ego_motion() {
        lf_ego_motion_t e;
        lf_ego_motion_init(&e);
        detail::check(lf_get_ego_motion(handle_, &e), [this] { return lf_last_error(handle_); });
        if (e.state != LF_EGO_OK) {
            static const char *const reasons[] = {"fitted", "not fitted: the result comes from a stage before interpolation",
                                                  "not metric: no stereo calibration",
                                                  "not fitted: too few matches agree on one rigid background motion",
                                                  "not fitted: the rigid background model is off"};
            const bool known = e.state >= 0 && e.state < 5;
            throw Error(LF_ERR_BAD_STATE, std::string("no ego-motion: ") +
                                              (known ? reasons[e.state] : "unknown state " + std::to_string(e.state)));
        }
        EgoMotion r;
        std::copy(e.transform, e.transform + 16, r.transform.begin());
        r.inliers = e.inliers;
        r.candidates = e.candidates;
        return r;
    }

    // The latest result's input quality (see Quality). Throws Error(LF_ERR_NOT_READY) before
    // there is a result.
    Quality quality() {
        uint32_t flags = 0;
        const char *reason = nullptr;
        detail::check(lf_get_quality(handle_, &flags, &reason), [this] { return lf_last_error(handle_); });
        return Quality{flags, reason ? reason : ""};
    }

    // A copy of the latest result's object motion (see ObjectMotion). Throws like ego_motion().
    ObjectMotion object_motion() {
        const ResultInfo i = info();
        ObjectMotion r;
        r.width = i.width;
        r.height = i.height;
        const std::size_t n = std::size_t{i.width} * i.height;
        r.motion.assign(3 * n, 0.0f);
        r.valid.assign(n, 0);
        lf_object_motion_buffers_t b;
        lf_object_motion_buffers_init(&b);
        b.width = i.width;
        b.height = i.height;
        b.motion = {r.motion.data(), uint64_t{i.width} * 3 * sizeof(float)};
        b.valid = {r.valid.data(), uint64_t{i.width}};
        detail::check(lf_get_object_motion(handle_, &b), [this] { return lf_last_error(handle_); });
        return r;
    }

    // Borrowed views of the latest result (see ResultViews for their lifetime). Throws
    // Error(LF_ERR_NOT_READY) before there is a result.
    ResultViews views() {
        lf_result_views_t v;
        lf_result_views_init(&v);
        detail::check(lf_get_result_views(handle_, &v), [this] { return lf_last_error(handle_); });
        ResultViews r;
        r.width = v.width;
        r.height = v.height;
        r.u = v.u;
        r.v = v.v;
        r.d0 = v.d0;
        r.d1 = v.d1;
        r.valid = v.valid;
        r.confidence = v.confidence;
        return r;
    }

#if LIDARFLOW_USE_OPENCV
    // The latest result as new cv::Mat copies owned by the caller (each call fetches and
    // copies again; see Result's and Points3d's conversions for what they hold). Throw
    // Error(LF_ERR_NOT_READY) before there is a result.
    cv::Mat flow() { return result(plane_u | plane_v).flow_mat(); }        // CV_32FC2
    cv::Mat disparity0() { return result(plane_d0).disparity0_mat(); }     // CV_32F
    cv::Mat disparity1() { return result(plane_d1).disparity1_mat(); }     // CV_32F
    cv::Mat confidence() { return result(plane_confidence).confidence_mat(); }  // CV_32F
    cv::Mat valid_mask() { return result(plane_valid).valid_mask(); }     // CV_8U 255/0
    cv::Mat points() { return points3d().points_mat(); }                   // CV_32FC3
    cv::Mat motion() { return points3d().motion_mat(); }                   // CV_32FC3
    cv::Mat object_motion_mat() { return object_motion().motion_mat(); }   // CV_32FC3, NaN holes
#endif

    // The owned handle, for C ABI calls; still owned by this object (null after a move).
    lf_estimator_t *get() const noexcept { return handle_; }
    // Gives up ownership: the caller frees the returned handle with lf_destroy().
    lf_estimator_t *release() noexcept { return std::exchange(handle_, nullptr); }

private:
    void create(const lf_options_t *options, const Calibration &calibration) {
        const lf_calibration_t c = calibration.to_c();
        lf_estimator_t *e = nullptr;
        detail::check(lf_create(options, &c, &e), [] { return lf_last_error(nullptr); });
        handle_ = e;
    }
    void push_c(int64_t timestamp_us, const ImageView &left, const ImageView &right, const lf_lidar_t *lidar) {
        const lf_image_t l = left.to_c(), r = right.to_c();
        detail::check(lf_push_frame(handle_, timestamp_us, &l, &r, lidar), [this] { return lf_last_error(handle_); });
    }

    lf_estimator_t *handle_ = nullptr;
};

}  // namespace lidarflow

#endif  // LIDARFLOW_HPP
