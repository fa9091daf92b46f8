// SPDX-License-Identifier: MIT
// Ray-casting renderer of the synthetic street scene and its exact ground truth.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <omp.h>
#include <opencv2/calib3d.hpp>

#include "core/error.hpp"
#include "core/maps.hpp"
#include "synth/model.hpp"
#include "synth/noise.hpp"
#include "synth/scene.hpp"
#include "synth/texture.hpp"

namespace lidarflow::synth {
namespace {

// Independent random streams per use, derived from the seed, so that e.g. changing the LiDAR
// noise leaves the images bit-identical.
enum StreamId : uint64_t {
    kNoiseLeft0 = 1,
    kNoiseRight0,
    kNoiseLeft1,
    kNoiseRight1,
    kLidarGrid0,
    kLidarGrid1,
    kLidarNoise0,
    kLidarNoise1,
    kDriveLeft,
    kDriveRight,
};

struct Rig {
    SceneModel model;
    StereoCamera cam;
    int width = 0, height = 0;

    V3 ray_dir(int t, double px, double py) const {
        return model.left[t].rot.apply(V3{(px - cam.cx) / cam.fx, (py - cam.cy) / cam.fy, 1.0});
    }
};

void validate(const SynthConfig &c) {
    auto bad = [](const std::string &m) { throw Error(ErrorCode::InvalidArgument, "synth: " + m); };
    if (c.width < 32 || c.width > 8192 || c.height < 32 || c.height > 8192)
        bad("image size " + std::to_string(c.width) + "x" + std::to_string(c.height) + " outside [32, 8192]");
    if (!std::isfinite(c.fx) || c.fx < 0) bad("fx must be finite and >= 0 (0 = automatic)");
    if (!std::isfinite(c.baseline) || c.baseline <= 0) bad("baseline must be finite and > 0");
    if (!std::isfinite(c.noise_sigma) || c.noise_sigma < 0) bad("noise_sigma must be finite and >= 0");
    if (!std::isfinite(c.lidar_noise) || c.lidar_noise < 0) bad("lidar_noise must be finite and >= 0");
    if (c.lidar_points < 0 || static_cast<int64_t>(c.lidar_points) > static_cast<int64_t>(c.width) * c.height)
        bad("lidar_points must be in [0, width*height]");
    if (c.supersampling < 1 || c.supersampling > 8) bad("supersampling must be in [1, 8]");
    if (c.threads < 0) bad("threads must be >= 0");
}

uint64_t stream_key(uint64_t seed, StreamId id) { return mix64(mix64(seed) + id * 0x9e3779b97f4a7c15ULL); }

int thread_count(const SynthConfig &c) { return c.threads > 0 ? c.threads : omp_get_max_threads(); }

uint8_t to_u8(double v) { return static_cast<uint8_t>(std::lround(std::min(std::max(v, 0.0), 255.0))); }

// Colour image of one view (area-sampled, plus sensor noise); optionally the depth Z and the
// disparity fx*B/Z of the pixel-centre rays (0 and kInvalidDisparity where nothing is hit).
void render_view(const Rig &rig, const SynthConfig &cfg, int t, bool right, uint64_t noise_key, cv::Mat &image,
                 cv::Mat1f *depth, DisparityMap *disp) {
    image.create(rig.height, rig.width, CV_8UC3);
    if (depth) depth->create(rig.height, rig.width);
    if (disp) disp->create(rig.height, rig.width);
    const int ss = cfg.supersampling;
    const V3 origin = rig.model.camera_centre(t, right);
#pragma omp parallel for num_threads(thread_count(cfg)) schedule(dynamic, 4)
    for (int y = 0; y < rig.height; ++y) {
        cv::Vec3b *row = image.ptr<cv::Vec3b>(y);
        for (int x = 0; x < rig.width; ++x) {
            Rgb sum{0, 0, 0};
            for (int j = 0; j < ss; ++j)
                for (int i = 0; i < ss; ++i) {
                    const V3 dir = rig.ray_dir(t, x + (i + 0.5) / ss - 0.5, y + (j + 0.5) / ss - 0.5);
                    const Hit h = cast_ray(rig.model, t, origin, dir);
                    if (h.label == kLabelNone) continue;
                    // Surface patch one sample covers: range / fx across the ray, stretched by
                    // 1/cos along it at grazing angles. The geometric mean of the two keeps
                    // ground texture crisp; the rest of the aliasing is left to supersampling.
                    const double len = norm(dir);
                    const double cosine = std::max(std::fabs(dot(dir, h.normal)) / len, 0.01);
                    const double footprint = h.t * len / rig.cam.fx / std::sqrt(cosine) / ss;
                    const Rgb c = surface_colour(rig.model, h, footprint);
                    for (int k = 0; k < 3; ++k) sum[k] += c[k];
                }
            const uint64_t pix = static_cast<uint64_t>(y) * rig.width + x;
            cv::Vec3b &out = row[x];
            for (int k = 0; k < 3; ++k) {  // k: R, G, B; OpenCV stores B, G, R
                double v = 255.0 * sum[k] / (ss * ss);
                if (cfg.noise_sigma > 0) v += cfg.noise_sigma * gaussian(noise_key, pix * 3 + k);
                out[2 - k] = to_u8(v);
            }
            if (!depth && !disp) continue;
            const Hit c = cast_ray(rig.model, t, origin, rig.ray_dir(t, x, y));
            const bool hit = c.label != kLabelNone;
            if (depth) (*depth)(y, x) = hit ? static_cast<float>(c.t) : 0.0f;
            if (disp) (*disp)(y, x) = hit ? static_cast<float>(rig.cam.disparity_from_depth(c.t)) : kInvalidDisparity;
        }
    }
}

// Exactly n pixels (fewer only if cells collapse on tiny images) on a jittered regular grid:
// rows of near-square cells, one uniformly placed point in the central 80 % of each cell.
std::vector<cv::Point> jittered_grid(int n, int w, int h, uint64_t key) {
    std::vector<cv::Point> pts;
    if (n <= 0) return pts;
    const int rows = std::min(n, std::max(1, static_cast<int>(std::lround(std::sqrt(double(n) * h / w)))));
    std::vector<uint8_t> taken(static_cast<size_t>(w) * h, 0);
    uint64_t counter = 0;
    for (int r = 0; r < rows; ++r) {
        const int cols = static_cast<int>(int64_t(r + 1) * n / rows - int64_t(r) * n / rows);
        const double ch = double(h) / rows, cw = double(w) / cols;
        for (int c = 0; c < cols; ++c) {
            const double jx = 0.1 + 0.8 * unit(mix64(key ^ mix64(counter++)));
            const double jy = 0.1 + 0.8 * unit(mix64(key ^ mix64(counter++)));
            const int x = std::min(w - 1, static_cast<int>((c + jx) * cw));
            const int y = std::min(h - 1, static_cast<int>((r + jy) * ch));
            uint8_t &t = taken[static_cast<size_t>(y) * w + x];
            if (t) continue;
            t = 1;
            pts.emplace_back(x, y);
        }
    }
    return pts;
}

// LiDAR returns are the true disparities of the view (exact, or with lidar_noise).
SparseLidar sample_lidar(const DisparityMap &disp, const SynthConfig &cfg, uint64_t grid_key, uint64_t noise_key) {
    SparseLidar out;
    out.width = disp.cols;
    out.height = disp.rows;
    uint64_t i = 0;
    for (const cv::Point &p : jittered_grid(cfg.lidar_points, disp.cols, disp.rows, grid_key)) {
        float d = disp(p.y, p.x);
        if (!disparity_valid(d)) continue;
        if (cfg.lidar_noise > 0) d = std::max(0.0f, d + static_cast<float>(cfg.lidar_noise * gaussian(noise_key, i++)));
        out.points.push_back({p.x, p.y, d});
    }
    return out;
}

// Per-pixel ground truth of the left t0 image (see scene.hpp for the definitions).
void ground_truth(const Rig &rig, const SynthConfig &cfg, SynthScene &s) {
    const int w = rig.width, h = rig.height;
    const SceneModel &m = rig.model;
    const StereoCamera &cam = rig.cam;
    s.disp0_occ = filled(h, w, kInvalidDisparity);
    s.disp0_noc = filled(h, w, kInvalidDisparity);
    s.disp1_occ = filled(h, w, kInvalidDisparity);
    s.disp1_noc = filled(h, w, kInvalidDisparity);
    s.flow_occ = FlowField::zeros(w, h);
    s.flow_noc = FlowField::zeros(w, h);
    s.textureless_mask = cv::Mat1b::zeros(h, w);
    s.shadow_mask = cv::Mat1b::zeros(h, w);
    s.labels0 = cv::Mat1b::zeros(h, w);
    const int uniform_box = m.textureless_box();
    const V3 left0 = m.camera_centre(0, false), right0 = m.camera_centre(0, true);
    const V3 left1 = m.camera_centre(1, false), right1 = m.camera_centre(1, true);
    const Yaw &yaw1 = m.left[1].rot;
#pragma omp parallel for num_threads(thread_count(cfg)) schedule(dynamic, 4)
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const Hit hit = cast_ray(m, 0, left0, rig.ray_dir(0, x, y));
            if (hit.label == kLabelNone) continue;
            s.labels0(y, x) = hit.label;
            if (uniform_box >= 0 && hit.label == kLabelFirstBox + uniform_box) s.textureless_mask(y, x) = 255;
            if (in_shadow(m, hit)) s.shadow_mask(y, x) = 255;

            const double d0 = cam.disparity_from_depth(hit.t);
            s.disp0_occ(y, x) = static_cast<float>(d0);
            if (x - d0 >= 0 && visible_from(m, 0, right0, hit.point)) s.disp0_noc(y, x) = static_cast<float>(d0);

            const V3 p1 = m.move_to_t1(hit.label, hit.point);
            const V3 c1 = yaw1.inverse(p1 - left1);
            if (c1.z <= 0.1) continue;
            const double u1 = cam.fx * c1.x / c1.z + cam.cx, v1 = cam.fy * c1.y / c1.z + cam.cy;
            if (!(u1 >= 0 && u1 <= w - 1 && v1 >= 0 && v1 <= h - 1)) continue;
            const double d1 = cam.disparity_from_depth(c1.z);
            const auto fu = static_cast<float>(u1 - x), fv = static_cast<float>(v1 - y);
            s.flow_occ.u(y, x) = fu;
            s.flow_occ.v(y, x) = fv;
            s.flow_occ.valid(y, x) = 1;
            s.disp1_occ(y, x) = static_cast<float>(d1);
            if (!visible_from(m, 1, left1, p1)) continue;
            s.flow_noc.u(y, x) = fu;
            s.flow_noc.v(y, x) = fv;
            s.flow_noc.valid(y, x) = 1;
            if (u1 - d1 >= 0 && visible_from(m, 1, right1, p1)) s.disp1_noc(y, x) = static_cast<float>(d1);
        }
    }
}

StereoCamera camera_of(const SynthConfig &config) {
    StereoCamera cam;
    cam.fx = cam.fy = config.fx > 0 ? config.fx : 0.58 * config.width;
    cam.cx = 0.5 * (config.width - 1);
    cam.cy = 0.46 * (config.height - 1);
    cam.baseline = config.baseline;
    return cam;
}

// Left camera pose at drive time k: the scene's one-step ego-motion (given in the camera frame
// of the step's start) composed k times.
Pose drive_pose(const SceneModel &base, int k) {
    Pose p;
    for (int i = 0; i < k; ++i) {
        p.centre = p.centre + p.rot.apply(base.left[1].centre);
        p.yaw += base.left[1].yaw;
        p.rot = Yaw(p.yaw);
    }
    return p;
}

// The model whose t0 and t1 are drive times k and k + 1: boxes move on linearly (translation
// and yaw per step as in the base scene), the camera by drive_pose.
SceneModel drive_model(const SceneModel &base, int k) {
    SceneModel m = base;
    m.left[0] = drive_pose(base, k);
    m.left[1] = drive_pose(base, k + 1);
    for (size_t i = 0; i < m.boxes.size(); ++i) {
        const Box &b = base.boxes[i];
        Box &out = m.boxes[i];
        for (int t = 0; t < 2; ++t) {
            const double steps = k + t;
            out.centre[t] = b.centre[0] + steps * (b.centre[1] - b.centre[0]);
            out.yaw[t] = b.yaw[0] + steps * (b.yaw[1] - b.yaw[0]);
            out.rot[t] = Yaw(out.yaw[t]);
        }
    }
    return m;
}

Rig drive_rig(const SynthConfig &config, int k, int last_time) {
    validate(config);
    require(k >= 0 && last_time < kMaxDriveFrames, ErrorCode::InvalidArgument,
            "synth: drive frame " + std::to_string(last_time) + " outside [0, " + std::to_string(kMaxDriveFrames) +
                ")");
    Rig rig;
    rig.width = config.width;
    rig.height = config.height;
    rig.cam = camera_of(config);
    rig.model = drive_model(make_street_scene(config.seed, config.baseline), k);
    // The renderer assumes no camera inside a box; a drive must end before it reaches a car.
    for (int t = 0; t < 2; ++t)
        for (const V3 &c : {rig.model.camera_centre(t, false), rig.model.camera_centre(t, true)})
            for (const Box &b : rig.model.boxes) {
                const V3 p = b.rot[t].inverse(c - b.centre[t]);
                require(std::fabs(p.x) > b.half.x + 0.5 || std::fabs(p.z) > b.half.z + 0.5, ErrorCode::InvalidArgument,
                        "synth: the drive of seed " + std::to_string(config.seed) + " reaches a car at frame " +
                            std::to_string(k + t) + ": use fewer frames or another seed");
            }
    return rig;
}

// The LiDAR -> left camera transform: Velodyne axes (x forward, y left, z up) -> camera axes
// (x right, y down, z forward), tilted down by 0.5 deg about the camera's x axis.
cv::Matx44d velo_to_left() {
    const double c = std::cos(0.5 * M_PI / 180.0), s = std::sin(0.5 * M_PI / 180.0);
    const cv::Matx33d axes(0, -1, 0, 0, 0, -1, 1, 0, 0);
    const cv::Matx33d tilt(1, 0, 0, 0, c, -s, 0, s, c);
    const cv::Matx33d R = tilt * axes;
    return cv::Matx44d(R(0, 0), R(0, 1), R(0, 2), -0.004, R(1, 0), R(1, 1), R(1, 2), -0.076, R(2, 0), R(2, 1),
                       R(2, 2), -0.272, 0, 0, 0, 1);
}

// Camera 2's offset t2 in camera 0's rectified frame (P_rect_02 = K [I | t2]), near KITTI's.
cv::Vec3d left_offset() { return {0.06, -0.0003, 0.004}; }

// R_rect_00: a 0.3 deg rotation about an oblique axis, of the size of KITTI's.
cv::Matx33d rect_rotation() {
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(0.6, -0.64, 0.48) * (0.3 * M_PI / 180.0), R);
    return R;
}

// Velodyne HDL-64-like ring pattern (see render_drive_frame).
constexpr double kDriveTopDeg = 2.0, kDriveBottomDeg = -24.8, kDriveRange = 120.0;
constexpr double kKittiFx = 721.0, kKittiRingDeg = 0.42, kKittiAzimuthDeg = 0.09;

std::vector<io::VelodynePoint> drive_scan(const Rig &rig) {
    const cv::Matx44d velo_to_cam = velo_to_left();
    const Pose &pose = rig.model.left[0];
    const V3 origin_cam{velo_to_cam(0, 3), velo_to_cam(1, 3), velo_to_cam(2, 3)};
    const V3 origin = pose.rot.apply(origin_cam) + pose.centre;
    // Angles spread by KITTI's focal over ours: the image gets KITTI's points per pixel.
    const double spread = kKittiFx / rig.cam.fx;
    const int rings = std::max(2, static_cast<int>((kDriveTopDeg - kDriveBottomDeg) / (kKittiRingDeg * spread)) + 1);
    const int per_ring = std::max(16, static_cast<int>(std::lround(360.0 / (kKittiAzimuthDeg * spread))));
    std::vector<io::VelodynePoint> points;
    for (int r = 0; r < rings; ++r) {
        const double el = (kDriveTopDeg + (kDriveBottomDeg - kDriveTopDeg) * r / (rings - 1)) * M_PI / 180.0;
        for (int a = 0; a < per_ring; ++a) {
            const double az = -M_PI + (a + 0.5) * 2.0 * M_PI / per_ring;
            const cv::Vec3d dv(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
            const cv::Vec3d dc = velo_to_cam.get_minor<3, 3>(0, 0) * dv;
            const V3 dir = pose.rot.apply(V3{dc[0], dc[1], dc[2]});
    const Hit h = cast_ray(rig.model, 0, origin, dir);
            if (h.label == kLabelNone || h.t > kDriveRange) continue;
            // Back to the LiDAR frame through the inverse rigid transform (R^T (X_cam - T)).
            const V3 cam = pose.rot.inverse(h.point - pose.centre) - origin_cam;
            const cv::Vec3d v = velo_to_cam.get_minor<3, 3>(0, 0).t() * cv::Vec3d(cam.x, cam.y, cam.z);
            points.push_back({static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]),
                              static_cast<float>(std::fabs(dot(dir, h.normal)))});
        }
    }
    return points;
}

}  // namespace

io::CamToCamCalib drive_calibration(const SynthConfig &config) {
    validate(config);
    const StereoCamera cam = camera_of(config);
    const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
    io::CamToCamCalib c;
    c.camera = cam;
    const cv::Vec3d t2 = left_offset(), t3 = t2 - cv::Vec3d(cam.baseline, 0, 0);
    const cv::Vec3d k2 = K * t2, k3 = K * t3;
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) c.P_rect_02(r, k) = c.P_rect_03(r, k) = K(r, k);
        c.P_rect_02(r, 3) = k2[r];
        c.P_rect_03(r, 3) = k3[r];
    }
    c.R_rect_00 = rect_rotation();
    return c;
}

cv::Matx44d drive_velo_to_cam() {
    // Tr = [R_rect_00^T 0; 0 1] * [I -t2; 0 1] * velo_to_left: velo_to_left_rect's chain inverted.
    const cv::Matx33d Rt = rect_rotation().t();
    const cv::Vec3d t2 = left_offset();
    cv::Matx44d undo = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) undo(r, k) = Rt(r, k);
        undo(r, 3) = -(Rt * t2)[r];
    }
    return undo * velo_to_left();
}

cv::Matx34d drive_camera_pose(const SynthConfig &config, int k) {
    const Pose p = drive_rig(config, k, k).model.left[0];
    // Yaw::apply as a matrix: the camera's axes in frame 0's camera, then its centre.
    return {p.rot.c, 0, p.rot.s, p.centre.x, 0, 1, 0, p.centre.y, -p.rot.s, 0, p.rot.c, p.centre.z};
}

DriveFrame render_drive_frame(const SynthConfig &config, int k) {
    const Rig rig = drive_rig(config, k, k);
    DriveFrame f;
    const uint64_t frame = static_cast<uint64_t>(k);
    render_view(rig, config, 0, false, mix64(stream_key(config.seed, kDriveLeft) + frame), f.left, nullptr, nullptr);
    render_view(rig, config, 0, true, mix64(stream_key(config.seed, kDriveRight) + frame), f.right, nullptr, nullptr);
    f.scan = drive_scan(rig);
    return f;
}

SynthScene render_drive_ground_truth(const SynthConfig &config, int k) {
    const Rig rig = drive_rig(config, k, k + 1);
    SynthScene s;
    s.config = config;
    s.camera = rig.cam;
    // The pair's ego-motion in its t0 camera frame: one step of the base scene.
    const Pose &p0 = rig.model.left[0], &p1 = rig.model.left[1];
    const V3 t = p0.rot.inverse(p1.centre - p0.centre);
    s.ego_translation = cv::Vec3d(t.x, t.y, t.z);
    s.ego_yaw = p1.yaw - p0.yaw;
    ground_truth(rig, config, s);
    return s;
}

SynthScene render(const SynthConfig &config) {
    validate(config);
    Rig rig;
    rig.width = config.width;
    rig.height = config.height;
    rig.cam = camera_of(config);
    rig.model = make_street_scene(config.seed, config.baseline);

    SynthScene s;
    s.config = config;
    s.camera = rig.cam;
    const V3 ego = rig.model.left[1].centre;
    s.ego_translation = cv::Vec3d(ego.x, ego.y, ego.z);
    s.ego_yaw = rig.model.left[1].yaw;

    DisparityMap disp_left1;
    render_view(rig, config, 0, false, stream_key(config.seed, kNoiseLeft0), s.left0, &s.depth_left0, nullptr);
    render_view(rig, config, 0, true, stream_key(config.seed, kNoiseRight0), s.right0, nullptr, nullptr);
    render_view(rig, config, 1, false, stream_key(config.seed, kNoiseLeft1), s.left1, &s.depth_left1, &disp_left1);
    render_view(rig, config, 1, true, stream_key(config.seed, kNoiseRight1), s.right1, nullptr, nullptr);
    ground_truth(rig, config, s);
    s.lidar0 = sample_lidar(s.disp0_occ, config, stream_key(config.seed, kLidarGrid0), stream_key(config.seed, kLidarNoise0));
    s.lidar1 = sample_lidar(disp_left1, config, stream_key(config.seed, kLidarGrid1), stream_key(config.seed, kLidarNoise1));
    return s;
}

}  // namespace lidarflow::synth
