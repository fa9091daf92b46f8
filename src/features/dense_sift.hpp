// SPDX-License-Identifier: MIT
#pragma once
// Dense SIFT-Flow-style descriptors: one descriptor per pixel, for patch matching.
//
// Why this layout: the matcher compares millions of descriptor pairs, so every pixel's
// descriptor is a contiguous run of `dim` uint8 values (row-major image of descriptors, stride
// padded to 16 bytes) that SSE2 loads directly. Each descriptor is 4x4 spatial cells x 8
// orientation bins (128 values) as in SIFT Flow; orientations are soft-binned between the two
// nearest bins and positions are bilinearly binned (triangular cell filter), so descriptors vary
// smoothly with position. `dim = 64` merges opposite orientations (gradient sign dropped) for a
// faster, smaller variant.
//
// Low contrast: the L2 normalisation divides by max(norm, norm_floor) so that flat, textureless
// regions keep near-zero descriptors instead of amplified noise (those are exactly the regions
// where the matcher should lean on LiDAR, not on noise).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "features/huge_page_allocator.hpp"

namespace lidarflow::features {

struct DenseSiftOptions {
    int cell_size = 2;         // cell side [px]; the descriptor spans 4 * cell_size px
    int dim = 128;             // 128 (16 cells x 8 signed bins) or 64 (16 cells x 4 unsigned bins)
    float clip = 0.2f;         // SIFT clipping of normalised entries before renormalising
    float norm_floor = 0.03f;  // lower bound of the normalising L2 norm (gray scale in [0, 1])
    // 8: one byte per value. 4: the full-contrast descriptor's values coded on 16 levels
    // spaced on the square root, two per byte (a 128-value descriptor takes 64 bytes: half the
    // memory, one cache line per sample), and its contrast (the low-contrast scale below) on
    // kContrastSteps steps in a byte of a separate plane.
    int bits = 8;
};

// Decoded values of the 16 codes of a packed descriptor of contrast index k (contrast k /
// kContrastSteps), on the scale of the 8-bit values. Distances of packed descriptors are
// distances of these values, so low-contrast descriptors keep the relative precision of the
// others. Filled during static initialisation; read-only afterwards.
constexpr int kContrastSteps = 255;
extern uint8_t kPackedLevels[kContrastSteps + 1][16];
static_assert(kContrastSteps == 255, "every value of the contrast byte must have its row");
inline const uint8_t *packed_levels(uint8_t contrast) { return kPackedLevels[contrast]; }

// Descriptor image. Owns its storage (a copy copies it), unless it was written into memory lent
// by its caller (compute_dense_sift with `memory`; a copy then refers to the same memory).
struct DescriptorImage {
    int width = 0, height = 0, dim = 0;  // dim: values per descriptor
    int bits = 8;                        // 8, or 4 (byte i: value i in the low nibble, i + dim/2 high)
    std::vector<uint8_t, HugePageAllocator<uint8_t>> data;  // width * height * stride(), row-major, pixel-major
    std::vector<uint8_t, HugePageAllocator<uint8_t>> contrast;  // bits 4: width * height indices; else empty
    // Lent storage used instead of data / contrast (null when owned).
    uint8_t *lent = nullptr, *lent_contrast = nullptr;

    int stride() const { return dim * bits / 8; }  // bytes per descriptor
    const uint8_t *bytes() const { return lent ? lent : data.data(); }
    uint8_t *bytes() { return lent ? lent : data.data(); }
    const uint8_t *contrast_bytes() const { return lent ? lent_contrast : contrast.data(); }
    uint8_t *contrast_bytes() { return lent ? lent_contrast : contrast.data(); }
    const uint8_t *at(int x, int y) const { return bytes() + (static_cast<size_t>(y) * width + x) * stride(); }
    uint8_t *at(int x, int y) { return bytes() + (static_cast<size_t>(y) * width + x) * stride(); }
    bool empty() const { return width == 0 || height == 0; }
};

// Descriptors of a single-channel CV_32F image with values in [0, 1]. Throws
// lidarflow::Error(InvalidArgument) for an empty / wrongly typed image or bad options.
// threads: OpenMP threads used (>= 1).
DescriptorImage compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options,
                                   int threads = 1);
// Same, written into `out`, whose storage is reused when it is large enough: a stream that
// recycles the images of a pair it no longer needs writes into pages it already has, instead of
// fresh ones the kernel must fault in and clear (~60 MB per full-resolution KITTI image). On an
// exception `out` is left empty or with undefined content.
void compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options, int threads,
                        DescriptorImage &out);

// Bytes compute_dense_sift writes for a width x height image: the descriptors, then (bits 4)
// the contrast plane.
size_t descriptor_bytes(int width, int height, const DenseSiftOptions &options);
// Same, written into `memory` (descriptor_bytes(...) bytes, 64-byte aligned), which `out` then
// refers to and which must outlive its use; `out`'s own storage is freed.
void compute_dense_sift(const cv::Mat1f &gray, const DenseSiftOptions &options, int threads,
                        DescriptorImage &out, uint8_t *memory);

// 8-bit gray or BGR(A) image -> CV_32F gray in [0, 1]. Throws InvalidArgument otherwise.
cv::Mat1f to_gray_float(const cv::Mat &image);

}  // namespace lidarflow::features
