// SPDX-License-Identifier: MIT
#include "synth/model.hpp"

#include <algorithm>

#include "synth/noise.hpp"

namespace lidarflow::synth {
namespace {

// Slab test against an oriented box. Keeps `best` when the box is farther or missed.
void hit_box(const Box &box, int time, uint8_t label, V3 origin, V3 dir, double t_min, Hit &best) {
    const Yaw &rot = box.rot[time];
    const V3 o = rot.inverse(origin - box.centre[time]);
    const V3 d = rot.inverse(dir);
    const double oc[3] = {o.x, o.y, o.z}, dc[3] = {d.x, d.y, d.z};
    const double hc[3] = {box.half.x, box.half.y, box.half.z};
    double t_near = -std::numeric_limits<double>::infinity();
    double t_far = std::numeric_limits<double>::infinity();
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(dc[a]) < 1e-15) {
            if (std::fabs(oc[a]) > hc[a]) return;
            continue;
        }
        double ta = (-hc[a] - oc[a]) / dc[a], tb = (hc[a] - oc[a]) / dc[a];
        if (ta > tb) std::swap(ta, tb);
        if (ta > t_near) {
            t_near = ta;
            axis = a;
        }
        t_far = std::min(t_far, tb);
    }
    // Cameras are never inside a box, so only entry points count.
    if (axis < 0 || t_near > t_far || t_near <= t_min || t_near >= best.t) return;
    const V3 p{o.x + t_near * d.x, o.y + t_near * d.y, o.z + t_near * d.z};
    const int side = dc[axis] > 0 ? 0 : 1;  // entering through the -axis face when moving +axis
    V3 n_local;
    if (axis == 0) {
        n_local.x = side ? 1 : -1;
        best.s = p.z;
        best.r = p.y;
    } else if (axis == 1) {
        n_local.y = side ? 1 : -1;
        best.s = p.x;
        best.r = p.z;
    } else {
        n_local.z = side ? 1 : -1;
        best.s = p.x;
        best.r = p.y;
    }
    best.t = t_near;
    best.label = label;
    best.face = axis * 2 + side;
    best.normal = rot.apply(n_local);
    best.point = origin + t_near * dir;
}

}  // namespace

int SceneModel::textureless_box() const {
    for (size_t i = 0; i < boxes.size(); ++i)
        if (boxes[i].textureless) return static_cast<int>(i);
    return -1;
}

V3 SceneModel::move_to_t1(uint8_t label, V3 p) const {
    if (label < kLabelFirstBox) return p;  // ground and wall are static
    const Box &b = boxes[label - kLabelFirstBox];
    return b.rot[1].apply(b.rot[0].inverse(p - b.centre[0])) + b.centre[1];
}

V3 SceneModel::camera_centre(int t, bool right) const {
    const Pose &pose = left[t];
    return right ? pose.centre + pose.rot.apply(V3{baseline, 0, 0}) : pose.centre;
}

Hit cast_ray(const SceneModel &scene, int time, V3 origin, V3 dir, double t_min) {
    Hit best;
    if (dir.y > 0) {
        const double t = (scene.ground_y - origin.y) / dir.y;
        if (t > t_min) {
            best.t = t;
            best.label = kLabelGround;
            best.point = origin + t * dir;
            best.s = best.point.x;
            best.r = best.point.z;
            best.normal = {0, -1, 0};
        }
    }
    if (dir.z > 0) {
        const double t = (scene.wall_z - origin.z) / dir.z;
        if (t > t_min && t < best.t) {
            best.t = t;
            best.label = kLabelWall;
            best.point = origin + t * dir;
            best.s = best.point.x;
            best.r = best.point.y;
            best.normal = {0, 0, -1};
        }
    }
    for (size_t i = 0; i < scene.boxes.size(); ++i)
        hit_box(scene.boxes[i], time, static_cast<uint8_t>(kLabelFirstBox + i), origin, dir, t_min, best);
    return best;
}

bool visible_from(const SceneModel &scene, int time, V3 from, V3 p) {
    // With dir = p - from the point sits at t = 1; a relative tolerance absorbs rounding of
    // the re-intersection with p's own surface (1e-7 of 50 m is 5 um, far below any gap).
    const Hit h = cast_ray(scene, time, from, p - from);
    return h.label != kLabelNone && h.t >= 1.0 - 1e-7;
}

SceneModel make_street_scene(uint64_t seed, double baseline) {
    LayoutRng rng(seed);
    SceneModel s;
    s.baseline = baseline;
    s.ground_y = 1.65;  // KITTI camera height
    s.wall_z = rng.uniform(40, 50);
    s.ground_key = rng.next();
    s.wall_key = rng.next();
    const double g = rng.uniform(0.92, 1.0);
    s.ground_colour = {g, g * 0.97, g * 0.92};
    s.wall_colour = {rng.uniform(0.75, 0.95), rng.uniform(0.6, 0.75), rng.uniform(0.45, 0.6)};

    // Ego-motion: forward about 0.9 m with a small yaw, as a car at ~30 km/h over 0.1 s.
    s.left[1].centre = {rng.uniform(-0.05, 0.05), 0, rng.uniform(0.7, 1.1)};
    s.left[1].yaw = rng.uniform(0.006, 0.018) * (rng.uniform(0, 1) < 0.5 ? -1 : 1);
    s.left[1].rot = Yaw(s.left[1].yaw);

    // The shadow falls on the left of the road in the near field, where LiDAR points land.
    s.shadow = {rng.uniform(-7.0, -6.0), rng.uniform(-1.2, -0.7), rng.uniform(6.5, 7.5), rng.uniform(12, 14)};

    struct Template {
        double x, z, yaw, w, h, l, dx, dz, dyaw;
        bool textureless;
    };
    // Car ahead, oncoming car, crossing car, right-lane car changing lanes, uniform van.
    const Template templates[] = {
        {0.2, 14, 0.0, 1.8, 1.5, 4.2, 0.0, 0.6, 0.0, false},
        {-3.6, 20, 0.0, 1.9, 1.6, 4.5, 0.0, -1.4, 0.0, false},
        {5.0, 27, 1.5708, 1.8, 1.7, 4.4, -0.9, 0.0, 0.0, false},
        {3.7, 16, 0.05, 1.8, 1.45, 4.0, -0.15, 0.9, 0.03, false},
        {4.4, 9, 0.1, 1.7, 1.8, 2.2, 0.05, 0.3, 0.0, true},
    };
    const std::array<double, 3> palette[] = {
        {0.85, 0.2, 0.15}, {0.2, 0.4, 0.85}, {0.9, 0.75, 0.2}, {0.25, 0.7, 0.35}, {0.6, 0.62, 0.68}};
    int k = 0;
    for (const Template &t : templates) {
        Box b;
        b.half = {t.w / 2, t.h / 2, t.l / 2};
        b.textureless = t.textureless;
        const double jitter = t.textureless ? 0.3 : 1.0;  // the uniform van must stay in view
        b.centre[0] = {t.x + jitter * rng.uniform(-0.3, 0.3), s.ground_y - b.half.y,
                       t.z + jitter * rng.uniform(-1.5, 1.5)};
        b.yaw[0] = t.yaw + rng.uniform(-0.05, 0.05);
        b.centre[1] = b.centre[0] + V3{t.dx + rng.uniform(-0.1, 0.1), 0, t.dz + rng.uniform(-0.2, 0.2)};
        b.yaw[1] = b.yaw[0] + t.dyaw + rng.uniform(-0.02, 0.02);
        b.rot[0] = Yaw(b.yaw[0]);
        b.rot[1] = Yaw(b.yaw[1]);
        const double shade = rng.uniform(0.85, 1.0);
        b.colour = {palette[k][0] * shade, palette[k][1] * shade, palette[k][2] * shade};
        b.key = rng.next();
        s.boxes.push_back(b);
        ++k;
    }
    return s;
}

}  // namespace lidarflow::synth
