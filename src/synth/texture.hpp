// SPDX-License-Identifier: MIT
#pragma once
// Procedural, seeded surface appearance of the synthetic scene. Internal to src/synth.
//
// Textures are attached to the surfaces (object coordinates), so a material point has the same
// colour in all four views: brightness constancy holds exactly up to sampling and sensor noise.
// Shading is a per-face constant for the same reason (no view- or pose-dependent lighting).
#include <array>

#include "synth/model.hpp"

namespace lidarflow::synth {

using Rgb = std::array<double, 3>;  // linear-ish RGB in [0, 1]

// Colour of the surface point in `hit`; `footprint` [m] is the size of the surface patch one
// sample covers, used to fade detail that the sampling cannot resolve (no aliasing).
Rgb surface_colour(const SceneModel &scene, const Hit &hit, double footprint);

// How much of the ground shadow covers `hit`: 1 inside, 0 outside, linear across a 25 cm
// penumbra centred on the ShadowArea border; in_shadow is amount >= 0.5.
double shadow_amount(const SceneModel &scene, const Hit &hit);
bool in_shadow(const SceneModel &scene, const Hit &hit);

}  // namespace lidarflow::synth
