// SPDX-License-Identifier: MIT
// The bridge's bot_core decoders (wire.cpp) on messages made by lcm-gen's own generated C
// encoder for the bot_core types: an encoder independent of the project's writer. Every prefix
// and every one-byte extension of a good message must be refused without a crash.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "wire.hpp"

// cmocka 1.1 has no extern "C" guard of its own; included last because of its macros.
extern "C" {
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
}

using namespace lidarflow::bridge;

namespace {

// A test image: value at (x, y, channel) differs per side, so swapped sides show.
struct Image {
    int32_t width, height, stride, channels;
    std::vector<uint8_t> data;
    Image(int32_t w, int32_t h, int32_t s, int32_t c, int side) : width(w), height(h), stride(s), channels(c) {
        data.assign(static_cast<size_t>(s) * static_cast<size_t>(h), 0xEE);  // padding: 0xEE
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w * c; ++x) data[static_cast<size_t>(y * s + x)] = static_cast<uint8_t>(7 * x + 13 * y + 101 * side);
    }
};

std::vector<uint8_t> encode_images(const std::vector<int16_t> &roles, std::vector<Image> &images, int32_t format,
                                   int64_t utime) {
    std::vector<bot_core_image_t> ims(images.size());
    char key[] = "exposure_us";
    uint8_t value[] = {1, 2, 3};
    bot_core_image_metadata_t meta{key, 3, value};
    for (size_t i = 0; i < images.size(); ++i) {
        bot_core_image_t &m = ims[i];
        std::memset(&m, 0, sizeof m);
        m.utime = utime;
        m.width = images[i].width;
        m.height = images[i].height;
        m.row_stride = images[i].stride;
        m.pixelformat = format;
        m.size = static_cast<int32_t>(images[i].data.size());
        m.data = images[i].data.data();
        m.nmetadata = static_cast<int32_t>(i % 2);  // with and without metadata
        m.metadata = &meta;
    }
    bot_core_images_t msg;
    msg.utime = utime;
    msg.n_images = static_cast<int32_t>(images.size());
    std::vector<int16_t> r = roles;
    msg.image_types = r.data();
    msg.images = ims.data();
    std::vector<uint8_t> buf(static_cast<size_t>(bot_core_images_t_encoded_size(&msg)));
    assert_int_equal(bot_core_images_t_encode(buf.data(), 0, static_cast<int>(buf.size()), &msg), buf.size());
    return buf;
}

// One bot_core.image_t on its own (a camera per channel), by lcm-gen's encoder.
std::vector<uint8_t> encode_image(Image &image, int32_t format, int64_t utime, bool with_metadata) {
    char key[] = "exposure_us";
    uint8_t value[] = {1, 2, 3};
    bot_core_image_metadata_t meta{key, 3, value};
    bot_core_image_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.width = image.width;
    m.height = image.height;
    m.row_stride = image.stride;
    m.pixelformat = format;
    m.size = static_cast<int32_t>(image.data.size());
    m.data = image.data.data();
    m.nmetadata = with_metadata ? 1 : 0;
    m.metadata = &meta;
    std::vector<uint8_t> buf(static_cast<size_t>(bot_core_image_t_encoded_size(&m)));
    assert_int_equal(bot_core_image_t_encode(buf.data(), 0, static_cast<int>(buf.size()), &m), buf.size());
    return buf;
}

void expect_pixels(const StereoMessage &m, const Image &left, const Image &right) {
    const int row = left.width * left.channels;
    assert_int_equal(m.msg().row_stride, row);
    for (int side = 0; side < 2; ++side) {
        const Image &im = side == 0 ? left : right;
        const lf_image_t v = side == 0 ? m.left() : m.right();
        for (int y = 0; y < im.height; ++y)
            assert_memory_equal(static_cast<const uint8_t *>(v.data) + static_cast<size_t>(y * row), im.data.data() + static_cast<size_t>(y * im.stride),
                                static_cast<size_t>(row));
    }
}

void expect_refused_prefixes_and_extension(const std::vector<uint8_t> &good, bool images) {
    for (size_t n = 0; n < good.size(); ++n) {
        StereoMessage m;
        LidarSweep s;
        const double T[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        const std::string err = images ? decode_bot_images(good.data(), n, m) : decode_bot_pointcloud(good.data(), n, T, s);
        assert_false(err.empty());
    }
    std::vector<uint8_t> longer = good;
    longer.push_back(0);
    StereoMessage m;
    LidarSweep s;
    const double T[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const std::string err = images ? decode_bot_images(longer.data(), longer.size(), m)
                                   : decode_bot_pointcloud(longer.data(), longer.size(), T, s);
    assert_true(err.find("wrong size") != std::string::npos);
}

void test_images_formats(void **) {
    const struct {
        int32_t bot, lf, channels;
    } formats[] = {{BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, LF_PIXEL_GRAY8, 1},
                   {BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB, LF_PIXEL_RGB8, 3},
                   {BOT_CORE_IMAGE_T_PIXEL_FORMAT_BGR, LF_PIXEL_BGR8, 3}};
    for (const auto &f : formats) {
        // Padded rows, the right image first, a disparity image beside them.
        std::vector<Image> images = {Image(5, 4, 5 * f.channels + 3, f.channels, 1),
                                     Image(5, 4, 5 * f.channels, f.channels, 2),
                                     Image(5, 4, 5 * f.channels + 1, f.channels, 0)};
        const std::vector<uint8_t> buf = encode_images(
            {BOT_CORE_IMAGES_T_RIGHT, BOT_CORE_IMAGES_T_DISPARITY, BOT_CORE_IMAGES_T_LEFT}, images, f.bot, 123456);
        StereoMessage m;
        assert_string_equal(decode_bot_images(buf.data(), buf.size(), m).c_str(), "");
        assert_int_equal(m.msg().utime, 123456);
        assert_int_equal(m.msg().width, 5);
        assert_int_equal(m.msg().height, 4);
        assert_int_equal(m.msg().pixel_format, f.lf);
        assert_false(m.has_frame_number());
        expect_pixels(m, images[2], images[0]);
        expect_refused_prefixes_and_extension(buf, true);
    }
}

void test_images_refused(void **) {
    std::vector<Image> two = {Image(4, 3, 4, 1, 0), Image(4, 3, 4, 1, 1)};
    auto refused = [](const std::vector<uint8_t> &buf, const char *what) {
        StereoMessage m;
        const std::string err = decode_bot_images(buf.data(), buf.size(), m);
        if (err.find(what) == std::string::npos) fail_msg("expected '%s', got '%s'", what, err.c_str());
    };
    refused(encode_images({BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_LEFT}, two, BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, 1),
            "more than one image tagged LEFT");
    refused(encode_images({BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_DISPARITY}, two, BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, 1),
            "no image tagged LEFT and one tagged RIGHT");
    refused(encode_images({BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_RIGHT}, two, 1498831189 /* UYVY */, 1),
            "unsupported pixelformat");
    std::vector<Image> differ = {Image(4, 3, 4, 1, 0), Image(4, 2, 4, 1, 1)};
    refused(encode_images({BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_RIGHT}, differ, BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, 1),
            "left and right differ");
    std::vector<Image> short_rows = {Image(4, 3, 4, 1, 0), Image(4, 3, 4, 1, 1)};
    short_rows[1].data.resize(8);  // 3 rows of 4 declared, 2 sent
    refused(encode_images({BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_RIGHT}, short_rows,
                          BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY, 1),
            "inconsistent dimensions");
    // A stereo_t where an images_t is expected names the type.
    StereoMessage m;
    const uint8_t other[16] = {1, 2, 3, 4, 5, 6, 7, 8};
    assert_true(decode_bot_images(other, sizeof other, m).find("bad fingerprint") != std::string::npos);
}

std::vector<uint8_t> encode_cloud(std::vector<float> &xyz, int channels) {
    const int32_t n = static_cast<int32_t>(xyz.size() / 3);
    std::vector<float *> rows(static_cast<size_t>(n));
    for (int32_t i = 0; i < n; ++i) rows[static_cast<size_t>(i)] = &xyz[3 * static_cast<size_t>(i)];
    std::vector<float> values(static_cast<size_t>(channels * n), 0.5f);
    std::vector<float *> chan(static_cast<size_t>(channels));
    for (int c = 0; c < channels; ++c) chan[static_cast<size_t>(c)] = values.data() + c * n;
    char frame[] = "velodyne", name[] = "intensity";
    std::vector<char *> names(static_cast<size_t>(channels), name);
    bot_core_pointcloud_t m;
    m.utime = 777;
    m.seq = 3;
    m.frame_id = frame;
    m.n_points = n;
    m.points = rows.data();
    m.n_channels = channels;
    m.channel_names = names.data();
    m.channels = chan.data();
    std::vector<uint8_t> buf(static_cast<size_t>(bot_core_pointcloud_t_encoded_size(&m)));
    assert_int_equal(bot_core_pointcloud_t_encode(buf.data(), 0, static_cast<int>(buf.size()), &m), buf.size());
    return buf;
}

void test_pointcloud(void **) {
    // KITTI-like: LiDAR x forward, y left, z up -> camera x right, y down, z forward, moved.
    const double T[16] = {0, -1, 0, 0.1, 0, 0, -1, -0.2, 1, 0, 0, 0.3, 0, 0, 0, 1};
    std::vector<float> xyz = {10, 1, -1, 20.5f, -2, 0.5f, 5, 0, 0};
    for (int channels : {0, 2}) {
        const std::vector<uint8_t> buf = encode_cloud(xyz, channels);
        LidarSweep s;
        assert_string_equal(decode_bot_pointcloud(buf.data(), buf.size(), T, s).c_str(), "");
        assert_int_equal(s.utime, 777);
        assert_int_equal(s.kind, LF_LIDAR_POINTS_CAMERA);
        assert_int_equal(s.xyz.size(), xyz.size());
        for (size_t i = 0; i < xyz.size() / 3; ++i)
            for (int r = 0; r < 3; ++r) {
                const double e = T[4 * r] * xyz[3 * i] + T[4 * r + 1] * xyz[3 * i + 1] + T[4 * r + 2] * xyz[3 * i + 2] + T[4 * r + 3];
                assert_true(s.xyz[3 * i + static_cast<size_t>(r)] == static_cast<float>(e));
            }
        expect_refused_prefixes_and_extension(buf, false);
        LidarSweep u;
        assert_true(decode_bot_pointcloud(buf.data(), buf.size(), nullptr, u).find("--lidar-to-camera") !=
                    std::string::npos);
        double bad[16];
        std::memcpy(bad, T, sizeof bad);
        bad[15] = 2;
        assert_true(decode_bot_pointcloud(buf.data(), buf.size(), bad, u).find("last row") != std::string::npos);
        assert_true(u.xyz.empty());
    }
    std::vector<float> nan = {1, NAN, 2};
    const std::vector<uint8_t> buf = encode_cloud(nan, 1);
    LidarSweep s;
    assert_true(decode_bot_pointcloud(buf.data(), buf.size(), T, s).find("not finite") != std::string::npos);
    std::vector<float> none;
    const std::vector<uint8_t> empty = encode_cloud(none, 0);
    assert_string_equal(decode_bot_pointcloud(empty.data(), empty.size(), T, s).c_str(), "");
    assert_true(s.xyz.empty());
}

}  // namespace

// Two image_t of one time from two channels: one stereo frame, as an images_t would give;
// every refusal of images_t applies, plus differing times, and every prefix and extension of
// either message is refused.
void test_image_pair(void **) {
    Image left(6, 3, 6 * 3 + 2, 3, 0), right(6, 3, 6 * 3, 3, 1);
    const int32_t rgb = BOT_CORE_IMAGE_T_PIXEL_FORMAT_RGB;
    const std::vector<uint8_t> l = encode_image(left, rgb, 777, true), r = encode_image(right, rgb, 777, false);
    int64_t utime = 0;
    assert_string_equal(check_bot_image(l.data(), l.size(), &utime).c_str(), "");
    assert_int_equal(utime, 777);
    StereoMessage m;
    assert_string_equal(decode_bot_image_pair(l.data(), l.size(), r.data(), r.size(), m).c_str(), "");
    assert_int_equal(m.msg().utime, 777);
    assert_int_equal(m.msg().pixel_format, LF_PIXEL_RGB8);
    assert_false(m.has_frame_number());
    expect_pixels(m, left, right);

    const std::vector<uint8_t> later = encode_image(right, rgb, 778, false);
    StereoMessage m2;
    assert_true(decode_bot_image_pair(l.data(), l.size(), later.data(), later.size(), m2).find("differ in utime") !=
                std::string::npos);
    Image small(5, 3, 15, 3, 1);
    const std::vector<uint8_t> s5 = encode_image(small, rgb, 777, false);
    StereoMessage m3;
    assert_true(decode_bot_image_pair(l.data(), l.size(), s5.data(), s5.size(), m3).find("left and right differ") !=
                std::string::npos);
    const std::vector<uint8_t> yuv = encode_image(right, 0x56595559, 777, false);
    assert_true(check_bot_image(yuv.data(), yuv.size(), &utime).find("unsupported pixelformat") != std::string::npos);
    // An images_t is not an image_t.
    std::vector<Image> both = {left, right};
    const std::vector<uint8_t> images = encode_images({BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_RIGHT}, both, rgb, 1);
    assert_true(check_bot_image(images.data(), images.size(), &utime).find("bad fingerprint") != std::string::npos);
    for (const std::vector<uint8_t> *good : {&l, &r}) {
        for (size_t n = 0; n < good->size(); ++n) assert_false(check_bot_image(good->data(), n, &utime).empty());
        std::vector<uint8_t> longer = *good;
        longer.push_back(0);
        assert_true(check_bot_image(longer.data(), longer.size(), &utime).find("wrong size") != std::string::npos);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_images_formats),
        cmocka_unit_test(test_images_refused),
        cmocka_unit_test(test_image_pair),
        cmocka_unit_test(test_pointcloud),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
