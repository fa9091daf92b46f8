// SPDX-License-Identifier: MIT
// Benchmark of stage 4 (LiDAR-supported robust interpolation) on the real KITTI frames:
// sparse matches sampled from the ground truth (density --density of the pixels with full
// scene-flow GT, a share --outliers of them corrupted), ~88 LiDAR points taken from the d0
// GT with the paper's protocol (5x5 window around regular grid nodes, nearest valid pixel),
// then interpolation with several settings. Prints seconds, peak RSS and the KITTI outlier
// rates (error > 3 px and > 5 % of the GT) of D0, D1, Fl and SF, all and non-occluded.
//
//   bench_interpolation [--root DIR] [--ids 000002,000003] [--density 0.05] [--outliers 0.05]
//                       [--threads 2] [--variants all|default|one] [--set key=value,...]
//                       [--blobs N]   (N discs of radius 24 px with coherently wrong matches)
// DIR defaults to $LIDARFLOW_KITTI_DIR. --set overrides InterpolationOptions fields of every
// variant (keys: see apply_overrides), for tuning.
//
// Real stage-3 inputs instead of GT samples (fast, reproducible tuning on what the pipeline
// really feeds the interpolator):
//   bench_interpolation --sparse SDIR [--lidar paper|velodyne|none] [--values real|gt]
// SDIR is the output of `lidarflow kitti --stage sparse --out SDIR` (disp_0/, disp_1/, flow/
// with holes); the LiDAR inputs are rebuilt exactly as `lidarflow kitti` builds them.
// --values gt keeps the pixel set but replaces every value by the ground truth (pixels without
// full GT are dropped): it separates the error of coverage (holes) from that of the outliers.
// Scores are the devkit's (hole-filled), plus SF outliers by distance to the nearest match.
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "interpolation/interpolator.hpp"
#include "consistency/options.hpp"
#include "consistency/sgm_check.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_submission.hpp"
#include <opencv2/imgproc.hpp>
#include "eval/kitti_runner.hpp"
#include "io/kitti_png.hpp"
#include "eval/kitti_eval.hpp"

using namespace lidarflow;

namespace {

struct Frame {
    std::string id;
    cv::Mat image;
    DisparityMap d0, d1, d0_noc, d1_noc;
    FlowField flow, flow_noc;
};

struct Input {
    SceneFlowField matches;
    SparseLidar lidar;
    SparseLidar lidar1;  // --sparse: D_l^1, as the estimator passes it
    DisparityMap hint;  // --sparse: the stage-2a SGM disparity, as the estimator passes it
    StereoCamera camera;  // from calib_cam_to_cam, as load_kitti_frame reads it
    int num_matches = 0, num_outliers = 0;
};

// xorshift-style generator; the bench must be reproducible run to run.
struct Rng {
    uint64_t s;
    explicit Rng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 1) {}
    uint64_t next() {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        return s;
    }
    double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
};

bool gt_valid(const Frame &f, int y, int x) {
    return f.d0(y, x) >= 0 && f.d1(y, x) >= 0 && f.flow.valid(y, x);
}

Input make_input(const Frame &f, double density, double outliers, int blobs, uint64_t seed) {
    const int w = f.image.cols, h = f.image.rows;
    Input in;
    in.matches = SceneFlowField::zeros(w, h);
    Rng rng(seed);
    auto put = [&](int y, int x) {
        in.matches.u(y, x) = f.flow.u(y, x);
        in.matches.v(y, x) = f.flow.v(y, x);
        in.matches.d0(y, x) = f.d0(y, x);
        in.matches.d1(y, x) = f.d1(y, x);
        in.matches.valid(y, x) = 1;
        in.matches.confidence(y, x) = 1;
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!gt_valid(f, y, x) || rng.uniform() >= density) continue;
            put(y, x);
            ++in.num_matches;
            if (rng.uniform() < outliers) {
                // A gross mismatch: every component off by 4..40 px in a random direction.
                auto off = [&] { return static_cast<float>((rng.uniform() < 0.5 ? -1 : 1) * (4 + 36 * rng.uniform())); };
                in.matches.u(y, x) += off();
                in.matches.v(y, x) += off();
                in.matches.d0(y, x) = std::max(0.0f, in.matches.d0(y, x) + off());
                in.matches.d1(y, x) = std::max(0.0f, in.matches.d1(y, x) + off());
                ++in.num_outliers;
            }
        }
    // Coherent failures (shadows, textureless areas): inside each blob every match is wrong
    // in the same way, which no robust fit can see as an outlier; LiDAR inside can.
    for (int b = 0; b < blobs; ++b) {
        int cx = 0, cy = 0;
        for (int tries = 0; tries < 1000; ++tries) {
            cx = static_cast<int>(rng.uniform() * w);
            cy = static_cast<int>(rng.uniform() * h);
            if (gt_valid(f, cy, cx)) break;
        }
        const float dd = static_cast<float>(6 + 10 * rng.uniform()), du = static_cast<float>(8 + 10 * rng.uniform());
        const int r = 24;
        for (int y = std::max(0, cy - r); y <= std::min(h - 1, cy + r); ++y)
            for (int x = std::max(0, cx - r); x <= std::min(w - 1, cx + r); ++x) {
                if (!in.matches.valid(y, x) || (x - cx) * (x - cx) + (y - cy) * (y - cy) > r * r) continue;
                in.matches.d0(y, x) += dd;
                in.matches.d1(y, x) += dd;
                in.matches.u(y, x) += du;
                ++in.num_outliers;
            }
    }
    // Paper protocol: regular grid, per node the valid d0 GT pixel nearest to it in a 5x5 window.
    in.lidar.width = w;
    in.lidar.height = h;
    const int step = 54;  // ~88 points per frame on average, as in the paper
    for (int cy = step / 2; cy < h; cy += step)
        for (int cx = step / 2; cx < w; cx += step) {
            int bx = -1, by = -1, bd = 1 << 30;
            for (int y = std::max(0, cy - 2); y <= std::min(h - 1, cy + 2); ++y)
                for (int x = std::max(0, cx - 2); x <= std::min(w - 1, cx + 2); ++x) {
                    const int d = (x - cx) * (x - cx) + (y - cy) * (y - cy);
                    if (gt_valid(f, y, x) && d < bd) bd = d, bx = x, by = y;
                }
            if (bx < 0) continue;
            in.lidar.points.push_back({bx, by, f.d0(by, bx)});
            if (!in.matches.valid(by, bx)) ++in.num_matches;
            put(by, bx);  // LiDAR pixels are matches too, with their (here exact) motion
        }
    return in;
}

// Stage-3 matches read back from a submission folder; a pixel is a match where all three maps
// are valid. values_gt: replace by the GT (drop pixels without full GT).
Input sparse_input(const std::string &dir, const Frame &f, const SparseLidar &lidar, bool values_gt) {
    const DisparityMap d0 = io::read_disparity_png(dir + "/disp_0/" + f.id + "_10.png");
    const DisparityMap d1 = io::read_disparity_png(dir + "/disp_1/" + f.id + "_10.png");
    const FlowField fl = io::read_flow_png(dir + "/flow/" + f.id + "_10.png");
    const int w = f.image.cols, h = f.image.rows;
    Input in;
    in.matches = SceneFlowField::zeros(w, h);
    in.lidar = lidar;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (d0(y, x) < 0 || d1(y, x) < 0 || !fl.valid(y, x)) continue;
            // KITTI's GT is semi-dense (LiDAR lines): a match between lines takes the GT of
            // the nearest GT pixel within 2 px.
            int gx = -1, gy = -1, best = 1 << 30;
            for (int yy = std::max(0, y - 2); yy <= std::min(h - 1, y + 2); ++yy)
                for (int xx = std::max(0, x - 2); xx <= std::min(w - 1, x + 2); ++xx) {
                    const int dd = (xx - x) * (xx - x) + (yy - y) * (yy - y);
                    if (dd < best && gt_valid(f, yy, xx)) best = dd, gx = xx, gy = yy;
                }
            const bool has_gt = gt_valid(f, y, x);
            if (values_gt && gx < 0) continue;
            auto &m = in.matches;
            m.u(y, x) = values_gt ? f.flow.u(gy, gx) : fl.u(y, x);
            m.v(y, x) = values_gt ? f.flow.v(gy, gx) : fl.v(y, x);
            m.d0(y, x) = values_gt ? f.d0(gy, gx) : d0(y, x);
            m.d1(y, x) = values_gt ? f.d1(gy, gx) : d1(y, x);
            m.valid(y, x) = 1;
            m.confidence(y, x) = 1;
            ++in.num_matches;
            if (!has_gt) continue;
            const bool b0 = eval::disparity_outlier(f.d0(y, x), m.d0(y, x));
            const bool b1 = eval::disparity_outlier(f.d1(y, x), m.d1(y, x));
            const bool bf = eval::flow_outlier(f.flow.u(y, x), f.flow.v(y, x), m.u(y, x), m.v(y, x));
            in.num_outliers += b0 || b1 || bf;
        }
    return in;
}

// SF outliers (occ GT) in bands of Euclidean distance to the nearest match: how much of the
// error sits in holes of the sparse input.
std::string coverage_breakdown(const SceneFlowField &est, const Frame &f, const SceneFlowField &matches) {
    cv::Mat1b holes(matches.valid.size());
    for (int y = 0; y < holes.rows; ++y)
        for (int x = 0; x < holes.cols; ++x) holes(y, x) = matches.valid(y, x) ? 0 : 255;
    cv::Mat1f dist;
    cv::distanceTransform(holes, dist, cv::DIST_L2, 3);
    const float edges[] = {0, 8, 24, 64, 1e9f};
    long n[4] = {0, 0, 0, 0}, bad_sf[4] = {0, 0, 0, 0}, bad_c[4][3] = {};
    for (int y = 0; y < holes.rows; ++y)
        for (int x = 0; x < holes.cols; ++x) {
            if (!gt_valid(f, y, x)) continue;
            int b = 0;
            while (dist(y, x) >= edges[b + 1]) ++b;
            const bool b0 = eval::disparity_outlier(f.d0(y, x), est.d0(y, x));
            const bool b1 = eval::disparity_outlier(f.d1(y, x), est.d1(y, x));
            const bool bf = eval::flow_outlier(f.flow.u(y, x), f.flow.v(y, x), est.u(y, x), est.v(y, x));
            ++n[b];
            bad_sf[b] += b0 || b1 || bf;
            bad_c[b][0] += b0, bad_c[b][1] += b1, bad_c[b][2] += bf;
        }
    long total = 0;
    for (long k : n) total += k;
    std::string out;
    const char *names[] = {"<8px", "8-24", "24-64", ">64"};
    for (int b = 0; b < 4; ++b) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "%s%s: %4.1f%% of px, SF %5.1f (D0 %4.1f D1 %4.1f Fl %4.1f) -> %4.1f pts",
                      b ? " | " : "", names[b], 100.0 * n[b] / std::max(1L, total),
                      100.0 * bad_sf[b] / std::max(1L, n[b]), 100.0 * bad_c[b][0] / std::max(1L, n[b]),
                      100.0 * bad_c[b][1] / std::max(1L, n[b]), 100.0 * bad_c[b][2] / std::max(1L, n[b]),
                      100.0 * bad_sf[b] / std::max(1L, total));
        out += buf;
    }
    return out;
}

struct Rates {
    double n = 0, d0 = 0, d1 = 0, fl = 0, sf = 0;
    void add(const Rates &o) { n += o.n, d0 += o.d0, d1 += o.d1, fl += o.fl, sf += o.sf; }
    std::string str() const {
        char b[160];
        std::snprintf(b, sizeof b, "D0 %5.2f  D1 %5.2f  Fl %5.2f  SF %5.2f", 100 * d0 / n, 100 * d1 / n,
                      100 * fl / n, 100 * sf / n);
        return b;
    }
};

bool bad(float err, float gt) { return err > 3.0f && err > 0.05f * std::fabs(gt); }

// KITTI SF outliers counted where all three GTs are valid; the estimate is dense already.
Rates score(const SceneFlowField &est, const DisparityMap &d0, const DisparityMap &d1, const FlowField &fl) {
    Rates r;
    for (int y = 0; y < est.height(); ++y)
        for (int x = 0; x < est.width(); ++x) {
            if (d0(y, x) < 0 || d1(y, x) < 0 || !fl.valid(y, x)) continue;
            const bool b0 = bad(std::fabs(est.d0(y, x) - d0(y, x)), d0(y, x));
            const bool b1 = bad(std::fabs(est.d1(y, x) - d1(y, x)), d1(y, x));
            const float du = est.u(y, x) - fl.u(y, x), dv = est.v(y, x) - fl.v(y, x);
            const float gm = std::hypot(fl.u(y, x), fl.v(y, x));
            const bool bf = bad(std::hypot(du, dv), gm);
            r.n += 1, r.d0 += b0, r.d1 += b1, r.fl += bf, r.sf += (b0 || b1 || bf);
        }
    return r;
}

double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_utime.tv_sec + 1e-6 * u.ru_utime.tv_usec + u.ru_stime.tv_sec + 1e-6 * u.ru_stime.tv_usec;
}

double peak_rss_mib() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss / 1024.0;
}

// "key=value,key=value" onto the options; unknown keys are an error.
void apply_overrides(const std::string &list, interpolation::InterpolationOptions &o) {
    std::stringstream ss(list);
    for (std::string kv; std::getline(ss, kv, ',');) {
        const size_t eq = kv.find('=');
        require(eq != std::string::npos, ErrorCode::InvalidArgument, "--set wants key=value, got " + kv);
        const std::string k = kv.substr(0, eq);
        const double v = std::stod(kv.substr(eq + 1));
        if (k == "edge_gain") o.edge_gain = static_cast<float>(v);
        else if (k == "K") o.num_neighbors = static_cast<int>(v);
        else if (k == "sigma") o.distance_sigma = static_cast<float>(v);
        else if (k == "d_inlier") o.disparity_inlier = static_cast<float>(v);
        else if (k == "f_inlier") o.flow_inlier = static_cast<float>(v);
        else if (k == "init") o.initial_hypotheses = static_cast<int>(v);
        else if (k == "iters") o.iterations = static_cast<int>(v);
        else if (k == "random") o.random_hypotheses = static_cast<int>(v);
        else if (k == "anchor_dist") o.lidar_anchor_distance = static_cast<float>(v);
        else if (k == "lidar_dtol") o.lidar_disparity_tolerance = static_cast<float>(v);
        else if (k == "lidar_mtol") o.lidar_match_tolerance = static_cast<float>(v);
        else if (k == "lidar_w") o.lidar_weight = static_cast<float>(v);
        else if (k == "sp_size") o.superpixels.region_size = static_cast<int>(v);
        else if (k == "sp_m") o.superpixels.compactness = static_cast<float>(v);
        else if (k == "sp_iters") o.superpixels.iterations = static_cast<int>(v);
        else if (k == "edge_sigma") o.edges.base_sigma = static_cast<float>(v);
        else if (k == "edge_contrast") o.edges.contrast_gain = static_cast<float>(v);
        else if (k == "use_lidar") o.use_lidar = v != 0;
        else if (k == "select") o.pixel_model_selection = v != 0;
        else if (k == "bilateral") o.edges.bilateral_prefilter = v != 0;
        else if (k == "d1_change") o.d1_from_change = v != 0;
        else if (k == "ego") o.ego_motion = v != 0;
        else if (k == "ego_rounds") o.ego.joint_rounds = static_cast<int>(v);
        else if (k == "rigid") o.rigid_ego_motion = v != 0;
        else if (k == "bg") o.background_hypothesis = v != 0;
        else if (k == "motion_anchors") o.lidar_motion_anchors = v != 0;
        else if (k == "occ") o.occlusion_reasoning = v != 0;
        else if (k == "occ_margin") o.occlusion_margin = static_cast<float>(v);
        else if (k == "bg_pref") o.background_preference = static_cast<float>(v);
        else if (k == "ego_lidar") o.ego_lidar_depth = v != 0;
        else if (k == "hint") o.use_geometry_hint = v != 0;
        else if (k == "hint_grid") o.hint_grid = static_cast<int>(v);
        else if (k == "hint_dist") o.hint_min_distance = static_cast<float>(v);
        else if (k == "hint_w") o.hint_weight = static_cast<float>(v);
        else if (k == "hint_r") o.hint_lidar_radius = static_cast<float>(v);
        else if (k == "hint_tol") o.hint_lidar_tolerance = static_cast<float>(v);
        else throw Error(ErrorCode::InvalidArgument, "--set: unknown key " + k);
    }
}

std::string arg(int argc, char **argv, const char *name, const std::string &def) {
    for (int i = 1; i + 1 < argc; ++i)
        if (std::strcmp(argv[i], name) == 0) return argv[i + 1];
    return def;
}

}  // namespace

int main(int argc, char **argv) try {
    const char *env = std::getenv("LIDARFLOW_KITTI_DIR");
    const std::string root = arg(argc, argv, "--root", env ? env : "");
    if (root.empty()) {
        std::fprintf(stderr, "bench_interpolation: set --root or LIDARFLOW_KITTI_DIR\n");
        return 2;
    }
    std::vector<std::string> ids;
    {
        std::stringstream ss(arg(argc, argv, "--ids", "000002,000003"));
        for (std::string s; std::getline(ss, s, ',');) ids.push_back(s);
    }
    const double density = std::stod(arg(argc, argv, "--density", "0.05"));
    const double outliers = std::stod(arg(argc, argv, "--outliers", "0.05"));
    const int threads = std::stoi(arg(argc, argv, "--threads", "2"));
    const int blobs = std::stoi(arg(argc, argv, "--blobs", "0"));
    const std::string which = arg(argc, argv, "--variants", "all");
    const bool all_variants = which == "all";

    io::KittiLayout kitti{root};
    std::vector<Frame> frames;
    for (const std::string &id : ids) {
        Frame f;
        f.id = id;
        f.image = io::read_image(kitti.left(id, 0));
        f.d0 = io::read_disparity_png(kitti.gt_disp0(id, true));
        f.d1 = io::read_disparity_png(kitti.gt_disp1(id, true));
        f.flow = io::read_flow_png(kitti.gt_flow(id, true));
        f.d0_noc = io::read_disparity_png(kitti.gt_disp0(id, false));
        f.d1_noc = io::read_disparity_png(kitti.gt_disp1(id, false));
        f.flow_noc = io::read_flow_png(kitti.gt_flow(id, false));
        frames.push_back(f);
    }
    const std::string sparse_dir = arg(argc, argv, "--sparse", "");
    const bool values_gt = arg(argc, argv, "--values", "real") == "gt";
    eval::LidarInputOptions lio;
    lio.protocol = eval::parse_protocol(arg(argc, argv, "--lidar", "paper"));
    lio.points = std::stoi(arg(argc, argv, "--points", lio.protocol == eval::LidarProtocol::Velodyne ? "0" : "88"));
    std::vector<Input> inputs;
    for (size_t i = 0; i < frames.size(); ++i) {
        if (sparse_dir.empty())
        {
            inputs.push_back(make_input(frames[i], density, outliers, blobs, 1000 + i));
            inputs.back().camera = io::read_calib_cam_to_cam(kitti.calib_cam_to_cam(frames[i].id)).camera;
        }
        else {
            const eval::KittiFrame kf = eval::load_kitti_frame(root, frames[i].id, lio);
            inputs.push_back(sparse_input(sparse_dir, frames[i], kf.input.lidar0, values_gt));
            inputs.back().camera = kf.input.camera;
            inputs.back().lidar1 = kf.input.lidar1;
            inputs.back().hint = consistency::compute_sgm_disparity(kf.input.left0, kf.input.right0,
                                                                    consistency::ConsistencyOptions{}.sgm);
        }
        std::printf("frame %s: %dx%d, %d matches (%.2f %% of pixels), %d corrupted, %zu LiDAR points\n",
                    frames[i].id.c_str(), frames[i].image.cols, frames[i].image.rows, inputs[i].num_matches,
                    100.0 * inputs[i].num_matches / frames[i].image.total(), inputs[i].num_outliers,
                    inputs[i].lidar.points.size());
    }

    struct Variant {
        std::string name;
        interpolation::InterpolationOptions o;
    };
    std::vector<Variant> variants;
    interpolation::InterpolationOptions base;
    base.num_threads = threads;
    apply_overrides(arg(argc, argv, "--set", ""), base);
    variants.push_back({"default (multi-scale edges, Interp+LiDAR)", base});
    if (which != "one") {
        auto o = base;
        o.use_lidar = false;
        variants.push_back({"Interp-only (use_lidar off)", o});
    }
    if (all_variants) {
        auto o = base;
        o.edges.method = interpolation::EdgeMethod::Gradient;
        variants.push_back({"single-scale gradient edges", o});
        o = base;
        o.edges.bilateral_prefilter = false;
        variants.push_back({"multi-scale, no bilateral prefilter", o});
        o = base;
        o.edge_gain = 0.0f;
        variants.push_back({"no edges (Euclidean neighbourhoods)", o});
        o = base;
        o.num_threads = 1;
        variants.push_back({"default, 1 thread", o});
    }

    for (const Variant &v : variants) {
        const interpolation::RobustInterpolator ri(v.o);
        Rates all, noc;
        double mean_sf = 0, mean_sf_noc = 0;
        double secs = 0, cpu = 0;
        std::printf("\n== %s\n", v.name.c_str());
        for (size_t i = 0; i < frames.size(); ++i) {
            const double c0 = cpu_seconds();
            const auto t0 = std::chrono::steady_clock::now();
            const interpolation::InterpolationResult r = ri.run(inputs[i].matches, inputs[i].lidar, frames[i].image, inputs[i].hint,
                                                             inputs[i].camera, inputs[i].lidar1);
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            secs += s;
            cpu += cpu_seconds() - c0;
            const Rates a = score(r.dense, frames[i].d0, frames[i].d1, frames[i].flow);
            const Rates n = score(r.dense, frames[i].d0_noc, frames[i].d1_noc, frames[i].flow_noc);
            all.add(a);
            noc.add(n);
            const auto &t = r.timings;
            std::printf("  %s: %.3f s (seeds %.3f, edges %.3f, superpixels %.3f, geodesic %.3f, models %.3f, output %.3f); "
                        "%d superpixels, LiDAR anchors geo %d / motion %d, ego-motion %s (%d inliers), %d hint seeds, %d occluded, "
                        "%d static d1, %d t1 LiDAR points\n",
                        frames[i].id.c_str(), s, t.seeds_s, t.edges_s, t.superpixels_s, t.geodesic_s, t.models_s,
                        t.output_s, r.num_superpixels, r.lidar_anchored_geometry, r.lidar_anchored_motion,
                        r.ego.valid ? "yes" : "no", r.ego.inliers, r.hint_seeds, r.occluded_seeds, r.static_d1_seeds,
                        r.lidar1_points);
            std::printf("    all: %s\n    noc: %s\n", a.str().c_str(), n.str().c_str());
            if (r.ego.valid && r.ego.calibrated)
                std::printf("    ego R %.5f %.5f %.5f | t %.3f %.3f %.3f m\n", r.ego.R[5], r.ego.R[2], r.ego.R[1],
                            r.ego.t[0], r.ego.t[1], r.ego.t[2]);
            else if (r.ego.valid)
                std::printf("    ego a %.4f %.4f %.4f %.4f | bx %.2f %.3f %.3f %.3f | by %.2f %.3f %.3f %.3f\n", r.ego.a[0],
                            r.ego.a[1], r.ego.a[2], r.ego.a[3], r.ego.bx[0], r.ego.bx[1], r.ego.bx[2], r.ego.bx[3],
                            r.ego.by[0], r.ego.by[1], r.ego.by[2], r.ego.by[3]);
            mean_sf += 100 * a.sf / a.n / frames.size();
            mean_sf_noc += 100 * n.sf / n.n / frames.size();
            if (!sparse_dir.empty())
                std::printf("    by distance to a match: %s\n",
                            coverage_breakdown(r.dense, frames[i], inputs[i].matches).c_str());
            if (std::getenv("BENCH_OUTLIERS")) {
                // Grey image, blue dots = matches, green dots = LiDAR; SF outliers coloured by cause.
                cv::Mat gray, pic;
                if (frames[i].image.channels() == 3) cv::cvtColor(frames[i].image, gray, cv::COLOR_BGR2GRAY);
                else gray = frames[i].image;
                cv::cvtColor(gray / 2, pic, cv::COLOR_GRAY2BGR);
                const Frame &f = frames[i];
                for (int y = 0; y < pic.rows; ++y)
                    for (int x = 0; x < pic.cols; ++x) {
                        cv::Vec3b &px = pic.at<cv::Vec3b>(y, x);
                        if (inputs[i].matches.valid(y, x)) px = {255, 128, 0};
                        if (!gt_valid(f, y, x)) continue;
                        const bool b0 = bad(std::fabs(r.dense.d0(y, x) - f.d0(y, x)), f.d0(y, x));
                        const bool b1 = bad(std::fabs(r.dense.d1(y, x) - f.d1(y, x)), f.d1(y, x));
                        const bool bf = bad(std::hypot(r.dense.u(y, x) - f.flow.u(y, x), r.dense.v(y, x) - f.flow.v(y, x)),
                                            std::hypot(f.flow.u(y, x), f.flow.v(y, x)));
                        // red: d0 wrong; magenta: d0 right, flow wrong; yellow: only d1 wrong
                        if (b0) px = {0, 0, 255};
                        else if (bf) px = {255, 0, 255};
                        else if (b1) px = {0, 255, 255};
                    }
                for (const LidarPoint &lp : inputs[i].lidar.points) pic.at<cv::Vec3b>(lp.y, lp.x) = {0, 160, 0};
                io::write_image(std::getenv("BENCH_OUTLIERS") + std::string("/") + (v.o.use_lidar ? "lidar_" : "only_") +
                                    frames[i].id + ".png", pic);
            }
            if (std::getenv("BENCH_DUMP")) io::write_submission(std::getenv("BENCH_DUMP") + std::string("/") +
                                                                    (v.o.use_lidar ? "lidar" : "only"),
                                                                frames[i].id, r.dense);
        }
        std::printf("  mean SF over frames: %.2f / noc %.2f\n", mean_sf, mean_sf_noc);
        std::printf("  pooled all: %s | noc: %s | mean %.3f s/frame (CPU %.3f s), peak RSS %.0f MiB\n",
                    all.str().c_str(), noc.str().c_str(), secs / frames.size(), cpu / frames.size(), peak_rss_mib());
    }
    return 0;
} catch (const lidarflow::Error &e) {
    std::fprintf(stderr, "bench_interpolation: %s\n", e.what());
    return 1;
}
