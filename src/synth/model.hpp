// SPDX-License-Identifier: MIT
#pragma once
// The synthetic world the renderer ray-casts: geometry, rigid motions and the seeded layout.
// Internal to src/synth (the public API is synth/scene.hpp).
//
// World frame = left camera at t0, KITTI camera axes: x right, y down, z forward [m].
// Yaw is a rotation about the y axis; the ground is the plane y = ground_y (> 0, below the
// camera), the background wall the plane z = wall_z. Boxes stand on the ground and move
// rigidly (translation + yaw about their own vertical axis) between t0 and t1.
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace lidarflow::synth {

struct V3 {
    double x = 0, y = 0, z = 0;
};
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline double norm(V3 a) { return std::sqrt(dot(a, a)); }

// Rotation about the y axis by `angle` [rad].
struct Yaw {
    double c = 1, s = 0;
    Yaw() = default;
    explicit Yaw(double angle) : c(std::cos(angle)), s(std::sin(angle)) {}
    V3 apply(V3 p) const { return {c * p.x + s * p.z, p.y, -s * p.x + c * p.z}; }
    V3 inverse(V3 p) const { return {c * p.x - s * p.z, p.y, s * p.x + c * p.z}; }
};

// Surface labels of the label map (SynthScene::labels0); boxes are kLabelFirstBox + index.
enum : uint8_t { kLabelNone = 0, kLabelGround = 1, kLabelWall = 2, kLabelFirstBox = 3 };

struct Box {
    V3 half;                // half extents in the box frame (x width, y height, z length)
    V3 centre[2];           // at t0, t1
    double yaw[2] = {0, 0}; // at t0, t1
    Yaw rot[2];             // Yaw(yaw[t]), cached: ray casting needs it for every ray
    bool textureless = false;
    std::array<double, 3> colour{};  // base RGB in [0, 1]
    uint64_t key = 0;                // texture seed
};

// Camera-to-world pose of the left camera: X_world = Yaw(yaw).apply(X_cam) + centre.
struct Pose {
    V3 centre;
    double yaw = 0;
    Yaw rot;  // Yaw(yaw), cached
};

// World-fixed rectangle [x0, x1] x [z0, z1] of the ground that lies in a strong shadow.
struct ShadowArea {
    double x0 = 0, x1 = 0, z0 = 0, z1 = 0;
};

struct SceneModel {
    double ground_y = 1.65;
    double wall_z = 45;
    std::vector<Box> boxes;
    Pose left[2];  // left camera at t0 (identity) and t1 (ego-motion)
    double baseline = 0.54;
    ShadowArea shadow;
    std::array<double, 3> ground_colour{}, wall_colour{};
    uint64_t ground_key = 0, wall_key = 0;

    int textureless_box() const;  // index into boxes, -1 when none
    // Where the material point at world position p (on surface `label`) is at t1.
    V3 move_to_t1(uint8_t label, V3 p) const;
    // Centre of the left (right = false) or right camera at time t.
    V3 camera_centre(int t, bool right) const;
};

struct Hit {
    double t = std::numeric_limits<double>::infinity();  // ray parameter: point = origin + t*dir
    uint8_t label = kLabelNone;
    int face = 0;        // box face 0..5 (axis * 2 + side)
    double s = 0, r = 0; // 2-D texture coordinates on the surface [m], attached to the object
    V3 point;            // world position
    V3 normal;           // unit world normal, facing the ray origin
};

// Nearest surface hit by origin + t*dir with t > t_min, at time t (0 or 1). No hit leaves
// label = kLabelNone.
Hit cast_ray(const SceneModel &scene, int time, V3 origin, V3 dir, double t_min = 1e-9);

// True when nothing at time `time` lies between `from` and the surface point `p` (seen from
// `from`), i.e. p is what a camera at `from` sees in that direction.
bool visible_from(const SceneModel &scene, int time, V3 from, V3 p);

// The seeded street scene: a textured ground and facade, four textured moving boxes (cars),
// one uniformly coloured moving box, a ground shadow, and ego-motion (forward + yaw).
SceneModel make_street_scene(uint64_t seed, double baseline);

}  // namespace lidarflow::synth
