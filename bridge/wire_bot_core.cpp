// SPDX-License-Identifier: MIT
// The bot_core decoders (images_t, image_t, pointcloud_t): each message is walked against its
// declared lengths before anything is read, and lcm-gen's decoder is never used.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "wire.hpp"
#include "wire_detail.hpp"

namespace lidarflow::bridge {

using detail::bytes_per_pixel;
using detail::read_be;

namespace {

// Bounds-checked walk over a big-endian LCM buffer: every read first checks that the bytes are
// there, so declared lengths never lead past the end (what lcm-gen's decoders do not check).
class WireReader {
public:
    WireReader(const void *data, size_t size) : p_(static_cast<const uint8_t *>(data)), size_(size) {}
    bool has(size_t n) const { return n <= size_ - pos_; }
    size_t pos() const { return pos_; }
    size_t left() const { return size_ - pos_; }
    const uint8_t *here() const { return p_ + pos_; }
    bool skip(size_t n) {
        if (!has(n)) return false;
        pos_ += n;
        return true;
    }
    bool i16(int64_t *v) { return get(2, v); }
    bool i32(int64_t *v) { return get(4, v); }
    bool i64(int64_t *v) { return get(8, v); }
    // An LCM string: int32 length counting the NUL, the bytes, the NUL.
    bool string(std::string *out) {
        int64_t n = 0;
        if (!i32(&n) || n < 1 || !has(static_cast<size_t>(n)) || p_[pos_ + static_cast<size_t>(n) - 1] != 0)
            return false;
        if (out) out->assign(reinterpret_cast<const char *>(p_ + pos_), static_cast<size_t>(n) - 1);
        pos_ += static_cast<size_t>(n);
        return true;
    }

private:
    bool get(int bytes, int64_t *v) {
        if (!has(static_cast<size_t>(bytes))) return false;
        *v = read_be(p_ + pos_, bytes);
        pos_ += static_cast<size_t>(bytes);
        return true;
    }
    const uint8_t *p_;
    size_t size_, pos_ = 0;
};

float get_be32f(const uint8_t *p) {
    const auto u = static_cast<uint32_t>(read_be(p, 4));
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

// One bot_core.image_t inside an images_t (nested: no fingerprint of its own).
struct BotImage {
    int64_t utime = 0, width = 0, height = 0, row_stride = 0, pixelformat = 0, size = 0;
    const uint8_t *data = nullptr;
};

std::string read_bot_image(WireReader &r, int index, BotImage *im) {
    if (!r.i64(&im->utime) || !r.i32(&im->width) || !r.i32(&im->height) || !r.i32(&im->row_stride) ||
        !r.i32(&im->pixelformat) || !r.i32(&im->size))
        return printf_string("truncated: image %d's header ends past the message", index);
    if (im->size < 0 || !r.has(static_cast<size_t>(im->size)))
        return printf_string("bad length field: image %d declares %lld data bytes, %zu left in the message", index,
                   (long long)im->size, r.left());
    im->data = r.here();
    r.skip(static_cast<size_t>(im->size));
    int64_t nmetadata = 0;
    if (!r.i32(&nmetadata)) return printf_string("truncated: image %d has no nmetadata", index);
    // Each entry takes at least 9 bytes (string length + NUL, n): bounds the loop by the message.
    if (nmetadata < 0 || static_cast<uint64_t>(nmetadata) > r.left() / 9)
        return printf_string("bad length field nmetadata = %lld in image %d", (long long)nmetadata, index);
    for (int64_t k = 0; k < nmetadata; ++k) {
        int64_t n = 0;
        if (!r.string(nullptr) || !r.i32(&n) || n < 0 || !r.skip(static_cast<size_t>(n)))
            return printf_string("truncated or bad metadata entry %lld of image %d", (long long)k, index);
    }
    return "";
}

int lf_format_of_bot(int64_t pixelformat) {
    switch (pixelformat) {
    case BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY: return LF_PIXEL_GRAY8;
    case BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB: return LF_PIXEL_RGB8;
    case BOT_CORE_IMAGE_T_PIXEL_FORMAT_BGR: return LF_PIXEL_BGR8;
    default: return 0;
    }
}

std::string check_fingerprint(const void *data, size_t size, const char *type, int64_t hash) {
    if (size > static_cast<size_t>(std::numeric_limits<int>::max()))
        return printf_string("oversized: %zu bytes, a %s holds at most %d", size, type, std::numeric_limits<int>::max());
    if (size < 8) return printf_string("truncated: %zu bytes, a %s needs at least 8", size, type);
    const int64_t got = read_be(static_cast<const uint8_t *>(data), 8);
    if (got != hash)
        return printf_string("bad fingerprint 0x%016llx (a %s has 0x%016llx): wrong message type on this channel",
                   (unsigned long long)got, type, (unsigned long long)hash);
    return "";
}

// The LEFT and RIGHT images (walked already) as one stereo frame at utime: same size and
// format, rows repacked. "" or the problem; `out` then holds nothing.
std::string stereo_from_bot_images(int64_t utime, const BotImage &L, const BotImage &R, StereoMessage &out) {
    const int format = lf_format_of_bot(L.pixelformat);
    if (format == 0)
        return printf_string("unsupported pixelformat %lld (GRAY %d, RGB %d, BGR %d)", (long long)L.pixelformat,
                   BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB,
                   BOT_CORE_IMAGE_T_PIXEL_FORMAT_BGR);
    if (R.pixelformat != L.pixelformat || R.width != L.width || R.height != L.height)
        return printf_string("left and right differ: %lldx%lld format %lld vs %lldx%lld format %lld", (long long)L.width,
                   (long long)L.height, (long long)L.pixelformat, (long long)R.width, (long long)R.height,
                   (long long)R.pixelformat);
    const int bpp = bytes_per_pixel(static_cast<int8_t>(format));
    if (L.width < 1 || L.height < 1 || L.width > 16384 || L.height > 16384)
        return printf_string("inconsistent dimensions: %lldx%lld (each side 1..16384)", (long long)L.width, (long long)L.height);
    for (const BotImage *im : {&L, &R}) {
        // The last row needs only width * bpp bytes; a driver may leave out the padding after it.
        if (im->row_stride < L.width * bpp || im->size < im->row_stride * (L.height - 1) + L.width * bpp)
            return printf_string("inconsistent dimensions: row_stride %lld, size %lld for %lldx%lld x %d bytes",
                       (long long)im->row_stride, (long long)im->size, (long long)L.width, (long long)L.height, bpp);
    }
    const size_t row = static_cast<size_t>(L.width * bpp), rows = static_cast<size_t>(L.height);
    std::vector<uint8_t> pixels(2 * row * rows);
    for (int k = 0; k < 2; ++k) {
        const BotImage &im = k == 0 ? L : R;
        for (size_t y = 0; y < rows; ++y)
            std::memcpy(&pixels[(k * rows + y) * row], im.data + y * static_cast<size_t>(im.row_stride), row);
    }
    lidarflow_stereo_t m{};
    m.utime = utime;
    m.width = static_cast<int32_t>(L.width);
    m.height = static_cast<int32_t>(L.height);
    m.row_stride = static_cast<int32_t>(row);
    m.pixel_format = static_cast<int8_t>(format);
    m.size = static_cast<int32_t>(row * rows);
    out.assign_packed(m, std::move(pixels));
    return "";
}

// A bot_core.image_t sent on its own (a camera per channel): fingerprint, then the same walk.
std::string read_standalone_bot_image(const void *data, size_t size, BotImage *im) {
    std::string err = check_fingerprint(data, size, "bot_core.image_t", __bot_core_image_t_get_hash());
    if (!err.empty()) return err;
    WireReader r(data, size);
    r.skip(8);
    err = read_bot_image(r, 0, im);
    if (!err.empty()) return err;
    if (r.left() != 0) return printf_string("wrong size: %zu bytes, the bot_core.image_t declares %zu", size, r.pos());
    if (lf_format_of_bot(im->pixelformat) == 0)
        return printf_string("unsupported pixelformat %lld (GRAY %d, RGB %d, BGR %d)", (long long)im->pixelformat,
                             BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB,
                             BOT_CORE_IMAGE_T_PIXEL_FORMAT_BGR);
    return "";
}

}  // namespace

std::string decode_bot_images(const void *data, size_t size, StereoMessage &out) {
    std::string err = check_fingerprint(data, size, "bot_core.images_t", __bot_core_images_t_get_hash());
    if (!err.empty()) return err;
    WireReader r(data, size);
    r.skip(8);
    int64_t utime = 0, n = 0;
    if (!r.i64(&utime) || !r.i32(&n)) return printf_string("truncated: %zu bytes, a bot_core.images_t needs at least 20", size);
    // An image_t takes at least 32 bytes (and its role 2): bounds n by the message.
    if (n < 0 || static_cast<uint64_t>(n) > r.left() / 32)
        return printf_string("bad length field n_images = %lld for %zu bytes", (long long)n, size);
    std::vector<int64_t> roles(static_cast<size_t>(n));
    for (auto &role : roles) r.i16(&role);
    int left = -1, right = -1;
    std::vector<BotImage> images(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
        err = read_bot_image(r, i, &images[static_cast<size_t>(i)]);
        if (!err.empty()) return err;
        int *slot = roles[static_cast<size_t>(i)] == BOT_CORE_IMAGES_T_LEFT    ? &left
                    : roles[static_cast<size_t>(i)] == BOT_CORE_IMAGES_T_RIGHT ? &right
                                                                              : nullptr;
        if (slot && *slot >= 0) return printf_string("more than one image tagged %s", slot == &left ? "LEFT" : "RIGHT");
        if (slot) *slot = i;
    }
    if (r.left() != 0) return printf_string("wrong size: %zu bytes, the bot_core.images_t declares %zu", size, r.pos());
    if (left < 0 || right < 0) return "no image tagged LEFT and one tagged RIGHT";
    return stereo_from_bot_images(utime, images[static_cast<size_t>(left)], images[static_cast<size_t>(right)], out);
}

std::string check_bot_image(const void *data, size_t size, int64_t *utime) {
    BotImage im;
    const std::string err = read_standalone_bot_image(data, size, &im);
    if (err.empty()) *utime = im.utime;
    return err;
}

std::string decode_bot_image_pair(const void *left, size_t left_size, const void *right, size_t right_size,
                                  StereoMessage &out) {
    BotImage L, R;
    std::string err = read_standalone_bot_image(left, left_size, &L);
    if (err.empty()) err = read_standalone_bot_image(right, right_size, &R);
    if (!err.empty()) return err;
    if (L.utime != R.utime)
        return printf_string("left and right images differ in utime (%lld, %lld)", (long long)L.utime, (long long)R.utime);
    return stereo_from_bot_images(L.utime, L, R, out);
}

std::string decode_bot_pointcloud(const void *data, size_t size, const double *T, LidarSweep &out) {
    std::string err = check_fingerprint(data, size, "bot_core.pointcloud_t", __bot_core_pointcloud_t_get_hash());
    if (!err.empty()) return err;
    WireReader r(data, size);
    r.skip(8);
    int64_t utime = 0, seq = 0, n = 0, channels = 0;
    if (!r.i64(&utime) || !r.i32(&seq) || !r.string(nullptr) || !r.i32(&n))
        return printf_string("truncated: %zu bytes end inside the bot_core.pointcloud_t header", size);
    if (n < 0 || static_cast<uint64_t>(n) > r.left() / 12)
        return printf_string("bad length field n_points = %lld for %zu bytes", (long long)n, size);
    const uint8_t *points = r.here();
    r.skip(12 * static_cast<size_t>(n));
    if (!r.i32(&channels) || channels < 0 || static_cast<uint64_t>(channels) > r.left() / 5)
        return printf_string("bad or missing length field n_channels (%lld) for %zu bytes", (long long)channels, size);
    for (int64_t c = 0; c < channels; ++c)
        if (!r.string(nullptr)) return printf_string("truncated or bad channel name %lld", (long long)c);
    const uint64_t channel_bytes = 4 * static_cast<uint64_t>(channels) * static_cast<uint64_t>(n);
    if (channel_bytes != r.left())
        return printf_string("wrong size: %zu bytes, the bot_core.pointcloud_t declares %llu", size,
                   (unsigned long long)(r.pos() + channel_bytes));
    if (!T) return "a bot_core.pointcloud_t needs the LiDAR -> camera transform (--lidar-to-camera)";
    err = check_lidar_to_camera(T);
    if (!err.empty()) return err;
    std::vector<float> xyz(3 * static_cast<size_t>(n)), lidar_xyz(xyz.size());
    for (size_t i = 0; i < static_cast<size_t>(n); ++i) {
        const double x = get_be32f(points + 12 * i), y = get_be32f(points + 12 * i + 4), z = get_be32f(points + 12 * i + 8);
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return printf_string("point %zu is not finite", i);
        lidar_xyz[3 * i] = static_cast<float>(x);
        lidar_xyz[3 * i + 1] = static_cast<float>(y);
        lidar_xyz[3 * i + 2] = static_cast<float>(z);
        for (int k = 0; k < 3; ++k) {
            const double c = T[4 * k] * x + T[4 * k + 1] * y + T[4 * k + 2] * z + T[4 * k + 3];
            if (!(std::fabs(c) <= std::numeric_limits<float>::max()))
                return printf_string("point %zu is out of float range after lidar_to_camera", i);
            xyz[3 * i + static_cast<size_t>(k)] = static_cast<float>(c);
        }
    }
    out.utime = utime;
    out.kind = LF_LIDAR_POINTS_CAMERA;
    out.xyz = std::move(xyz);
    out.in_lidar_frame = true;
    out.lidar_xyz = std::move(lidar_xyz);
    std::copy(T, T + 16, out.lidar_to_camera);
    return "";
}

}  // namespace lidarflow::bridge
