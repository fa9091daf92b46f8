// SPDX-License-Identifier: MIT
#include "synth/texture.hpp"

#include <algorithm>

#include "synth/noise.hpp"

namespace lidarflow::synth {
namespace {

constexpr double kGroundMean = 0.45;
// Shadow: light reduced to 14 %, and the remaining texture contrast to 30 % of that, so the
// texture there is at the level of the sensor noise (image matching has nothing to hold on to).
constexpr double kShadowLight = 0.14;
constexpr double kShadowContrast = 0.3;
constexpr double kPenumbra = 0.25;  // [m], width of the soft shadow border

// Box-filtered step (0 below `edge`, 1 above) for a filter of `width`: a hard edge as area
// sampling sees it, so edges stay smooth under bilinear interpolation.
double soft_step(double x, double edge, double width) {
    return std::min(std::max((x - edge) / width + 0.5, 0.0), 1.0);
}

// Box-filtered indicator of [a, b].
double soft_band(double x, double a, double b, double width) {
    return soft_step(x, a, width) - soft_step(x, b, width);
}

double lane_marking(double x, double z, double fp) {
    // Dashed lane separators at +-1.75 m (3 m dashes every 9 m), solid road edges at -5.4 and
    // 7.6 m, all 15 cm wide.
    const double w = std::max(2.0 * fp, 0.02), hw = 0.075;
    const double zz = std::fmod(std::fabs(z) + 1.0, 9.0);
    const double dash = soft_band(zz, 0.0, 3.0, w) + soft_step(zz, 9.0, w);  // wraps at 9 m
    const double ax = std::fabs(x);
    double m = dash * soft_band(ax, 1.75 - hw, 1.75 + hw, w);
    m += soft_band(x, -5.4 - hw, -5.4 + hw, w) + soft_band(x, 7.6 - hw, 7.6 + hw, w);
    return std::min(m, 1.0);
}

Rgb ground(const SceneModel &sc, const Hit &h, double fp) {
    double l = kGroundMean + 0.9 * fbm(h.s, h.r, sc.ground_key, 3.0, 10, 0.8, fp);
    l += (0.85 - l) * lane_marking(h.s, h.r, fp);
    return {l * sc.ground_colour[0], l * sc.ground_colour[1], l * sc.ground_colour[2]};
}

Rgb wall(const SceneModel &sc, const Hit &h, double fp) {
    const double base = 0.75 + 0.6 * fbm(h.s, h.r, sc.wall_key, 6.0, 9, 0.78, fp);
    Rgb c{sc.wall_colour[0] * base, sc.wall_colour[1] * base, sc.wall_colour[2] * base};
    // Windows on a 3.2 m x 3.0 m grid, each with its own brightness (no two alike).
    const double cw = 3.2, ch = 3.0;
    const double gx = std::floor(h.s / cw), gy = std::floor(h.r / ch);
    const double fx = h.s / cw - gx, fy = h.r / ch - gy;
    const double edge = std::max(2.0 * fp, 0.05);
    const double w = band_weight(1.8, fp) * soft_band(fx * cw, 0.2 * cw, 0.8 * cw, edge) *
                     soft_band(fy * ch, 0.25 * ch, 0.8 * ch, edge);
    if (w > 0) {
        const double b = 0.1 + 0.35 * unit(hash2(sc.wall_key, static_cast<int64_t>(gx), static_cast<int64_t>(gy)));
        const double n = b * (1.0 + 0.5 * fbm(h.s, h.r, sc.wall_key + 1, 0.8, 5, 0.7, fp));
        const Rgb glass{n * 0.8, n * 0.9, n * 1.1};
        for (int i = 0; i < 3; ++i) c[i] += w * (glass[i] - c[i]);
    }
    return c;
}

double face_shade(int face) {
    // Top brightest, sides, then front/back; the bottom is never seen from above the ground.
    static const double kShade[6] = {0.82, 0.78, 1.0, 0.5, 0.68, 0.72};
    return kShade[face];
}

Rgb box(const Box &b, const Hit &h, double fp) {
    const double shade = face_shade(h.face);
    if (b.textureless) return {b.colour[0] * shade, b.colour[1] * shade, b.colour[2] * shade};
    const uint64_t key = b.key + static_cast<uint64_t>(h.face) * 0x51ed27ULL;
    double l = 0.75 + 1.0 * fbm(h.s, h.r, key, 1.2, 9, 0.8, fp);
    // Soft-edged checker of period 2p: strong edges for descriptors, faded when too small.
    const double p = 0.3, k = 3.14159265358979 / p;
    const double checker = std::min(std::max(3.0 * std::sin(k * h.s) * std::sin(k * h.r), -1.0), 1.0);
    l += 0.12 * checker * band_weight(2 * p, fp);
    const double tint = 0.15 * fbm(h.s, h.r, key + 7, 2.0, 3, 0.5, fp);
    return {b.colour[0] * l * shade * (1 + tint), b.colour[1] * l * shade, b.colour[2] * l * shade * (1 - tint)};
}

}  // namespace

double shadow_amount(const SceneModel &scene, const Hit &hit) {
    if (hit.label != kLabelGround) return 0.0;
    const ShadowArea &a = scene.shadow;
    return soft_band(hit.point.x, a.x0, a.x1, kPenumbra) * soft_band(hit.point.z, a.z0, a.z1, kPenumbra);
}

bool in_shadow(const SceneModel &scene, const Hit &hit) { return shadow_amount(scene, hit) >= 0.5; }

Rgb surface_colour(const SceneModel &scene, const Hit &hit, double footprint) {
    Rgb c{0, 0, 0};
    if (hit.label == kLabelGround) {
        c = ground(scene, hit, footprint);
        const double a = shadow_amount(scene, hit);
        for (int i = 0; a > 0 && i < 3; ++i) {
            const double mean = kGroundMean * scene.ground_colour[i];
            c[i] += a * (kShadowLight * (mean + kShadowContrast * (c[i] - mean)) - c[i]);
        }
    } else if (hit.label == kLabelWall) {
        c = wall(scene, hit, footprint);
    } else if (hit.label >= kLabelFirstBox) {
        c = box(scene.boxes[hit.label - kLabelFirstBox], hit, footprint);
    }
    for (double &v : c) v = std::min(std::max(v, 0.0), 1.0);
    return c;
}

}  // namespace lidarflow::synth
