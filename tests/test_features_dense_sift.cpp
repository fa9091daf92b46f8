// SPDX-License-Identifier: MIT
// Dense SIFT descriptors: layout, normalisation, shift equivariance, low-contrast handling and
// argument validation.
#include "test_support.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <new>
#include <string>
#include <random>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "features/dense_sift.hpp"
#include "features/huge_page_allocator.hpp"

using namespace lidarflow;
using namespace lidarflow::features;

namespace {

cv::Mat1f texture(int w, int h, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    cv::Mat1f img(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) img(y, x) = u(rng);
    cv::GaussianBlur(img, img, cv::Size(0, 0), 1.2);
    return img;
}

double length(const uint8_t *d, int dim) {
    double s = 0;
    for (int i = 0; i < dim; ++i) s += double(d[i]) * d[i];
    return std::sqrt(s);
}

void layout_and_length(void **) {
    const cv::Mat1f img = texture(40, 30, 1);
    for (int dim : {128, 64}) {
        DenseSiftOptions o;
        o.dim = dim;
        const DescriptorImage d = compute_dense_sift(img, o);
        assert_int_equal(d.width, 40);
        assert_int_equal(d.height, 30);
        assert_int_equal(d.dim, dim);
        assert_int_equal(d.data.size(), 40u * 30u * dim);
        // Textured pixel: normalised, clipped and renormalised to 512 (rounding tolerance).
        const double len = length(d.at(20, 15), dim);
        assert_true(len > 490.0 && len < 530.0);
    }
}

void flat_image_gives_zero_descriptors(void **) {
    const cv::Mat1f flat(20, 24, 0.5f);
    const DescriptorImage d = compute_dense_sift(flat, DenseSiftOptions{});
    for (uint8_t v : d.data) assert_int_equal(v, 0);
}

void low_contrast_is_not_amplified(void **) {
    // The same texture at 1/100 contrast: far below the norm floor, so much shorter descriptors.
    const cv::Mat1f img = texture(40, 30, 2);
    const cv::Mat1f faint = img * 0.01f + 0.5f;
    const DescriptorImage a = compute_dense_sift(img, DenseSiftOptions{});
    const DescriptorImage b = compute_dense_sift(faint, DenseSiftOptions{});
    assert_true(length(b.at(20, 15), 128) < 0.2 * length(a.at(20, 15), 128));
}

void shift_equivariance(void **) {
    const cv::Mat1f img = texture(60, 40, 3);
    cv::Mat1f shifted(40, 60, 0.0f);
    img(cv::Rect(0, 0, 55, 37)).copyTo(shifted(cv::Rect(5, 3, 55, 37)));
    const DescriptorImage a = compute_dense_sift(img, DenseSiftOptions{});
    const DescriptorImage b = compute_dense_sift(shifted, DenseSiftOptions{});
    for (int y = 12; y < 28; ++y)
        for (int x = 12; x < 45; ++x)
            assert_memory_equal(a.at(x, y), b.at(x + 5, y + 3), 128);
    // ... and a different position does not match (the test can fail).
    assert_memory_not_equal(a.at(20, 20), b.at(20, 20), 128);
}

void thread_count_does_not_change_output(void **) {
    const cv::Mat1f img = texture(50, 33, 4);
    for (int bits : {8, 4}) {
        DenseSiftOptions o;
        o.bits = bits;
        const DescriptorImage a = compute_dense_sift(img, o, 1);
        const DescriptorImage b = compute_dense_sift(img, o, 3);
        assert_true(a.data == b.data);
        assert_true(a.contrast == b.contrast);
    }
}

// Descriptors are computed in bands of rows with their own halo: a row must not depend on where
// the band seams fall. A crop puts the seams at other rows of the same content; away from the
// crop's borders both must agree byte for byte (also across thread counts and cell sizes).
void rows_do_not_depend_on_band_seams(void **) {
    const cv::Mat1f img = texture(70, 300, 5);
    const int top = 37, bottom = 237;
    for (int cell : {2, 3})
        for (int dim : {128, 64}) {
            DenseSiftOptions o;
            o.cell_size = cell;
            o.dim = dim;
            const DescriptorImage full = compute_dense_sift(img, o, 1);
            const DescriptorImage full3 = compute_dense_sift(img, o, 3);
            assert_true(full.data == full3.data);
            const DescriptorImage crop = compute_dense_sift(img.rowRange(top, bottom).clone(), o, 2);
            const int margin = 2 * cell + 4;  // cell offsets + vertical blur + gradient rows
            for (int y = top + margin; y < bottom - margin; ++y)
                assert_memory_equal(full.at(0, y), crop.at(0, y - top), static_cast<size_t>(70) * dim);
            // The crop's own border rows do differ (the comparison can fail).
            assert_memory_not_equal(full.at(0, top), crop.at(0, 0), static_cast<size_t>(70) * dim);
        }
}

// Writing into an existing image reuses its storage when it is large enough and gives exactly
// the fresh result; a smaller image grows.
void reuses_output_storage(void **) {
    DescriptorImage out = compute_dense_sift(texture(80, 90, 6), DenseSiftOptions{});
    const uint8_t *storage = out.data.data();
    const cv::Mat1f small = texture(50, 40, 7);
    compute_dense_sift(small, DenseSiftOptions{}, 2, out);
    assert_ptr_equal(out.data.data(), storage);
    assert_int_equal(out.width, 50);
    assert_int_equal(out.height, 40);
    assert_true(out.data == compute_dense_sift(small, DenseSiftOptions{}).data);
    const cv::Mat1f big = texture(100, 120, 8);
    compute_dense_sift(big, DenseSiftOptions{}, 2, out);
    assert_int_equal(out.data.size(), 100u * 120u * 128u);
    assert_true(out.data == compute_dense_sift(big, DenseSiftOptions{}).data);
}

void gray_conversion(void **) {
    cv::Mat bgr(4, 5, CV_8UC3, cv::Scalar(255, 255, 255));
    const cv::Mat1f g = to_gray_float(bgr);
    assert_int_equal(g.cols, 5);
    assert_true(std::abs(g(2, 2) - 1.0f) < 1e-6f);
    cv::Mat gray(3, 3, CV_8UC1, cv::Scalar(51));
    assert_true(std::abs(to_gray_float(gray)(1, 1) - 0.2f) < 1e-6f);
}

void invalid_arguments(void **) {
    auto expect_invalid = [](auto fn) {
        try {
            fn();
            fail_msg("expected lidarflow::Error");
        } catch (const Error &e) {
            assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::InvalidArgument));
        }
    };
    expect_invalid([] { compute_dense_sift(cv::Mat1f(), DenseSiftOptions{}); });
    expect_invalid([] {
        DenseSiftOptions o;
        o.dim = 96;
        compute_dense_sift(cv::Mat1f(8, 8, 0.f), o);
    });
    expect_invalid([] {
        DenseSiftOptions o;
        o.cell_size = 0;
        compute_dense_sift(cv::Mat1f(8, 8, 0.f), o);
    });
    expect_invalid([] {
        DenseSiftOptions o;
        o.norm_floor = NAN;
        compute_dense_sift(cv::Mat1f(8, 8, 0.f), o);
    });
    expect_invalid([] {
        DenseSiftOptions o;
        o.bits = 6;
        compute_dense_sift(cv::Mat1f(8, 8, 0.f), o);
    });
    expect_invalid([] { compute_dense_sift(cv::Mat1f(8, 8, 0.f), DenseSiftOptions{}, 0); });
    expect_invalid([] { to_gray_float(cv::Mat()); });
    expect_invalid([] { to_gray_float(cv::Mat(4, 4, CV_16UC1, cv::Scalar(0))); });
    expect_invalid([] { to_gray_float(cv::Mat(4, 4, CV_8UC2, cv::Scalar(0))); });
}

// Value i of a packed descriptor (features::DenseSiftOptions::bits = 4), decoded.
int packed_value(const DescriptorImage &d, int x, int y, int i) {
    const uint8_t byte = d.at(x, y)[i % (d.dim / 2)];
    return packed_levels(d.contrast[static_cast<size_t>(y) * d.width + x])[i < d.dim / 2 ? byte & 15 : byte >> 4];
}

// 4-bit descriptors: half the bytes, a contrast index per pixel, and decoded values close to
// the 8-bit ones at normal and at low contrast (the contrast keeps a faint texture's relative
// precision instead of rounding its small values to the lowest levels).
void packed_descriptors_follow_the_byte_ones(void **) {
    const cv::Mat1f normal = texture(48, 40, 5);
    const cv::Mat1f faint = normal * 0.004f + 0.5f;  // gradients below the contrast floor
    for (int dim : {128, 64})
        for (const cv::Mat1f &img : {normal, faint}) {
            DenseSiftOptions o8, o4;
            o8.dim = o4.dim = dim;
            o4.bits = 4;
            const DescriptorImage d8 = compute_dense_sift(img, o8), d4 = compute_dense_sift(img, o4, 2);
            assert_int_equal(d4.stride(), dim / 2);
            assert_int_equal(d4.bits, 4);
            assert_int_equal(d4.data.size(), 48u * 40u * dim / 2);
            assert_int_equal(d4.contrast.size(), 48u * 40u);
            assert_true(d8.contrast.empty());
            for (int y = 4; y < 36; y += 3)
                for (int x = 4; x < 44; x += 3) {
                    double diff = 0, len = 0;
                    for (int i = 0; i < dim; ++i) {
                        const double e = packed_value(d4, x, y, i) - d8.at(x, y)[i];
                        diff += e * e;
                        len += double(d8.at(x, y)[i]) * d8.at(x, y)[i];
                    }
                    if (&img == &faint) {
                        const int c = d4.contrast[static_cast<size_t>(y) * 48 + x];
                        assert_true(c > 0 && c < kContrastSteps);
                        assert_true(std::sqrt(len) < 400.0);
                    }
                    // Error of the decoded descriptor: ~6 % typical for the 16 square-root
                    // levels (a tenth as the bound), one contrast step of the length 512, and
                    // two roundings to integers (the bytes' and the decoded values'), whose
                    // typical norm is sqrt(dim / 6) (twice that as the bound).
                    const double bound = 0.1 * std::sqrt(len) + 512.0 / kContrastSteps + 2.0 * std::sqrt(dim / 6.0);
                    if (std::sqrt(diff) > bound)
                        fail_msg("dim %d pixel (%d, %d): |packed - bytes| %.1f of %.1f", dim, x, y, std::sqrt(diff),
                                 std::sqrt(len));
                }
        }
    // The flat image: zero contrast, zero descriptors.
    DenseSiftOptions o4;
    o4.bits = 4;
    const DescriptorImage flat = compute_dense_sift(cv::Mat1f(20, 24, 0.5f), o4);
    for (uint8_t c : flat.contrast) assert_int_equal(c, 0);
}

long resident_kib() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line))
        if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
    return -1;
}

// Large descriptor blocks: 2 MiB-aligned, writable to the last byte, handed back to the system
// on release (glibc's heap kept freed coarse levels, and the peak RSS grew frame after frame),
// and an impossible size is std::bad_alloc, not a crash.
void huge_page_allocator_blocks(void **) {
    // glibc raises its mmap threshold to the size of a mapped block that is freed: after this,
    // a malloc'd 16 MiB block comes from the heap and stays resident when freed.
    void *volatile warm = std::malloc(std::size_t(20) << 20);
    assert_non_null(warm);
    std::memset(warm, 1, std::size_t(20) << 20);
    std::free(warm);

    HugePageAllocator<uint8_t> a;
    const std::size_t n = (std::size_t(16) << 20) + 12345;  // not a multiple of 2 MiB
    const long before = resident_kib();
    uint8_t *p = a.allocate(n);
    assert_int_equal(reinterpret_cast<std::uintptr_t>(p) % (std::size_t(2) << 20), 0);
    std::memset(p, 0x5a, n);
    assert_int_equal(p[n - 1], 0x5a);
    const long touched = resident_kib();
    a.deallocate(p, n);
    const long after = resident_kib();
#if !LIDARFLOW_HUGE_PAGE_ALLOC_USES_MALLOC
    if (before > 0) {
        assert_true(touched - before > 15 * 1024);
        assert_true(touched - after > 15 * 1024);
    }
#else
    (void)before, (void)touched, (void)after;
#endif
    uint8_t *small = a.allocate(100);
    small[99] = 1;
    a.deallocate(small, 100);
#if !LIDARFLOW_HUGE_PAGE_ALLOC_USES_MALLOC
    // (Under the sanitizers their allocator aborts on such a size unless told otherwise.)
    bool threw = false;
    try {
        a.deallocate(a.allocate(std::size_t(1) << 62), std::size_t(1) << 62);
    } catch (const std::bad_alloc &) {
        threw = true;
    }
    assert_true(threw);
#endif
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(layout_and_length),
        cmocka_unit_test(flat_image_gives_zero_descriptors),
        cmocka_unit_test(low_contrast_is_not_amplified),
        cmocka_unit_test(shift_equivariance),
        cmocka_unit_test(thread_count_does_not_change_output),
        cmocka_unit_test(rows_do_not_depend_on_band_seams),
        cmocka_unit_test(reuses_output_storage),
        cmocka_unit_test(gray_conversion),
        cmocka_unit_test(packed_descriptors_follow_the_byte_ones),
        cmocka_unit_test(invalid_arguments),
        cmocka_unit_test(huge_page_allocator_blocks),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
