// SPDX-License-Identifier: MIT
// lidarflow demo: renders the built-in synthetic scene, writes it in the KITTI layout with
// pictures of its ground truth, then runs the complete estimator on it twice — with the sparse
// LiDAR (LiDAR-Flow) and image-only — and writes both results, their error maps and scores,
// overall and inside the scene's hard regions (textureless box + dark shadow).
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "eval/metrics.hpp"
#include "io/kitti_png.hpp"
#include "io/kitti_submission.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/option_assignments.hpp"
#include "synth/scene.hpp"
#include "synth/write_kitti.hpp"
#include "synth_args.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"
#include "viz/legend.hpp"
#include "viz/flow_color.hpp"
#include "viz/overlay.hpp"

namespace lidarflow::cli {
namespace {

double percent_valid(const DisparityMap &d) {
    int n = 0;
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x) n += disparity_valid(d(y, x));
    return 100.0 * n / static_cast<double>(d.total());
}

double percent_valid(const FlowField &f) { return 100.0 * cv::countNonZero(f.valid) / static_cast<double>(f.valid.total()); }

int points_in(const SparseLidar &l, const cv::Mat1b &mask) {
    int n = 0;
    for (const LidarPoint &p : l.points) n += mask(p.y, p.x) != 0;
    return n;
}

// White where the flow GT is non-occluded, grey where it exists only as occluded, black where
// the point leaves the image.
const cv::Scalar kNonOccluded(255, 255, 255), kOccluded(110, 110, 110), kLeavesImage(0, 0, 0);
const cv::Scalar kTextureless(255, 255, 0), kShadow(255, 0, 255);

cv::Mat flow_coverage(const synth::SynthScene &s) {
    cv::Mat out(s.flow_occ.valid.size(), CV_8UC3, kLeavesImage);
    out.setTo(kOccluded, s.flow_occ.valid);
    out.setTo(kNonOccluded, s.flow_noc.valid);
    return out;
}

// Ground truth restricted to a mask (elsewhere invalid), to score one region of the image.
eval::GroundTruth masked_gt(const DisparityMap &d0, const DisparityMap &d1, const FlowField &flow, const cv::Mat1b &mask) {
    eval::GroundTruth g{DisparityMap(d0.size(), kInvalidDisparity), DisparityMap(d1.size(), kInvalidDisparity),
                        FlowField::zeros(flow.width(), flow.height())};
    d0.copyTo(g.d0, mask);
    d1.copyTo(g.d1, mask);
    flow.u.copyTo(g.flow.u, mask);
    flow.v.copyTo(g.flow.v, mask);
    flow.valid.copyTo(g.flow.valid, mask);
    return g;
}

struct DemoRun {
    const char *name;
    pipeline::EstimatorResult result;
    eval::FrameScore all, hard;
};

int run_demo(int argc, char **argv) {
    Args args("demo", argc, argv,
                        {{"out", true, "DIR  output folder (default demo-out)"},
               {"seed", true, "S  scene seed (default 1)"},
               {"threads", true, "N  OpenMP threads of the estimator (default: every usable CPU, fewer while others are busy)"},
               {"preset", true, "NAME speed/accuracy preset: default | paper | balanced | fast | realtime"},
               {"set", true, "K=V,.. any option key of the C ABI (lidarflow.h), after the preset"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    const std::string out = args.str("out", "demo-out");
    require(!out.empty(), ErrorCode::InvalidArgument, "demo: --out must not be empty");
    const synth::SynthConfig config = synth_config_from_args(args, "demo");
    const std::string id = "000000";

    const auto t0 = std::chrono::steady_clock::now();
    const synth::SynthScene s = synth::render(config);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    synth::write_kitti(s, out, id);

    // One disparity scale for d0, d1 and the LiDAR dots, and one flow scale (the ground
    // truth's), so colours compare across pictures; each picture carries its key below it.
    double max_d = 0;
    cv::minMaxLoc(s.disp0_occ, nullptr, &max_d);
    const auto scale = static_cast<float>(max_d);
    viz::FlowColorOptions flow_colors;
    flow_colors.max_flow = static_cast<float>(viz::flow_color_scale(s.flow_occ));
    const auto flow_picture = [&](const FlowField &f) {
        return viz::with_flow_legend(viz::flow_to_color(f, flow_colors), flow_colors.max_flow, flow_colors.style);
    };
    const auto disparity_picture = [&](const DisparityMap &d) {
        return viz::with_disparity_legend(viz::disparity_to_color(d, scale), scale);
    };
    using Mark = viz::LegendMark;
    const std::string dir = out + "/viz/" + id;
    struct Picture {
        std::string path, what;
        cv::Mat image;
    };
    const std::vector<Picture> pictures = {
        {dir + "_inputs.png", "left|right at t0 (top) and t1 (bottom), LiDAR dots coloured by disparity",
         viz::with_disparity_legend(viz::tile({viz::draw_lidar(s.left0, s.lidar0, scale), s.right0,
                                               viz::draw_lidar(s.left1, s.lidar1, scale), s.right1},
                                              2),
                                    scale, "LiDAR dots: disparity [px] (near = bright)")},
        {dir + "_flow_gt.png", "GT optical flow, KITTI colour wheel (occ)", flow_picture(s.flow_occ)},
        {dir + "_flow_coverage.png", "flow GT: white non-occluded, grey occluded, black leaves the image",
         viz::with_marks_legend(flow_coverage(s), {{Mark::Glyph::Swatch, kNonOccluded, "non-occluded"},
                                                   {Mark::Glyph::Swatch, kOccluded, "occluded"},
                                                   {Mark::Glyph::Swatch, kLeavesImage, "leaves the image"}})},
        {dir + "_disp0_gt.png", "GT disparity d0 (occ)", disparity_picture(s.disp0_occ)},
        {dir + "_disp1_gt.png", "GT disparity d1 in the t0 frame (occ), same scale as d0",
         disparity_picture(s.disp1_occ)},
        {dir + "_masks.png", "left t0 with the textureless box (cyan) and the shadow (magenta)",
         viz::with_marks_legend(
             viz::overlay_mask(viz::overlay_mask(s.left0, s.textureless_mask, kTextureless, 0.55), s.shadow_mask,
                               kShadow, 0.55),
             {{Mark::Glyph::Swatch, kTextureless, "textureless box (hard region)"},
              {Mark::Glyph::Swatch, kShadow, "shadow (hard region)"}})},
    };
    for (const Picture &p : pictures) io::write_image(p.path, p.image);

    // The estimator, with LiDAR and image-only, on the same frames.
    const pipeline::FrameInput in{s.left0, s.right0, s.left1, s.right1, s.lidar0, s.lidar1, s.camera, {}};
    eval::FrameGroundTruth gt, gt_hard;
    gt.occ = {s.disp0_occ, s.disp1_occ, s.flow_occ};
    gt.has_noc = true;
    gt.noc = {s.disp0_noc, s.disp1_noc, s.flow_noc};
    const cv::Mat1b hard = s.textureless_mask | s.shadow_mask;
    gt_hard.occ = masked_gt(s.disp0_occ, s.disp1_occ, s.flow_occ, hard);
    std::vector<DemoRun> runs;
    for (const bool lidar : {true, false}) {
        pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(args.str("preset", "default"));
        opt.threads = args.integer("threads", opt.threads);
        pipeline::apply_option_assignments(opt, args.list("set"));
        opt.use_lidar = lidar;
        DemoRun r{lidar ? "lidarflow" : "image-only", pipeline::Estimator(opt).run(in), {}, {}};
        const SceneFlowField &f = r.result.dense;
        r.all = eval::evaluate_frame(gt, f, eval::EvalOptions{});
        r.hard = eval::evaluate_frame(gt_hard, f, eval::EvalOptions{});
        const std::string est = out + "/" + r.name;
        io::write_submission(est, id, f);
        const std::string vdir = out + "/viz/" + id + "_" + r.name;
        io::write_image(vdir + "_flow.png", flow_picture(io::field_flow(f)));
        io::write_image(vdir + "_disp0.png", disparity_picture(io::field_disparity0(f)));
        io::write_image(vdir + "_disp0_error.png", viz::with_error_legend(viz::disparity_error_image(
                                                       io::field_disparity0(f), s.disp0_occ, s.disp0_noc)));
        io::write_image(vdir + "_flow_error.png",
                        viz::with_error_legend(viz::flow_error_image(io::field_flow(f), s.flow_occ, s.flow_noc)));
        runs.push_back(std::move(r));
    }

    std::printf("lidarflow demo: the built-in synthetic scene, its exact ground truth, and the estimator's\n");
    std::printf("result with the sparse LiDAR (lidarflow) and without it (image-only).\n\n");
    std::printf("scene     seed %llu, %dx%d, fx %.1f px, baseline %.2f m, rendered in %.0f ms\n",
                static_cast<unsigned long long>(config.seed), config.width, config.height, s.camera.fx,
                s.camera.baseline, ms);
    std::printf("ego       forward %.2f m, lateral %+.2f m, yaw %+.2f deg\n", s.ego_translation[2],
                s.ego_translation[0], s.ego_yaw * 180.0 / 3.14159265358979);
    std::printf("LiDAR     %zu points at t0 (in I_l^0), %zu at t1 (in I_l^1, own grid)\n", s.lidar0.points.size(),
                s.lidar1.points.size());
    std::printf("GT        density occ/noc: d0 %.1f/%.1f %%, d1 %.1f/%.1f %%, flow %.1f/%.1f %%\n",
                percent_valid(s.disp0_occ), percent_valid(s.disp0_noc), percent_valid(s.disp1_occ),
                percent_valid(s.disp1_noc), percent_valid(s.flow_occ), percent_valid(s.flow_noc));
    std::printf("hard      textureless box %d px (%d LiDAR points), shadow %d px (%d LiDAR points)\n",
                cv::countNonZero(s.textureless_mask), points_in(s.lidar0, s.textureless_mask),
                cv::countNonZero(s.shadow_mask), points_in(s.lidar0, s.shadow_mask));
    std::printf("\nKITTI outliers [%%] (error > 3 px and > 5 %%), all pixels with ground truth | hard regions only\n");
    std::printf("  %-11s %6s %6s %6s %6s  | %6s %6s %6s %6s   %s\n", "", "D0", "D1", "Fl", "SF", "D0", "D1", "Fl", "SF",
                "seconds");
    for (const DemoRun &r : runs) {
        const eval::ComponentScores &a = r.all.dense.occ, &h = r.hard.dense.occ;
        std::printf("  %-11s %6.2f %6.2f %6.2f %6.2f  | %6.2f %6.2f %6.2f %6.2f   %.2f\n", r.name, a.d0.outlier_pct(),
                    a.d1.outlier_pct(), a.fl.outlier_pct(), a.sf.outlier_pct(), h.d0.outlier_pct(),
                    h.d1.outlier_pct(), h.fl.outlier_pct(), h.sf.outlier_pct(), r.result.total_seconds);
    }
    std::printf("\nwrote KITTI layout for frame %s under %s/ (image_2, image_3, disp_occ/noc_0/1, flow_occ/noc,\n",
                id.c_str(), out.c_str());
    std::printf("      calib_cam_to_cam, lidar_0, lidar_1, masks)\n");
    for (const Picture &p : pictures) std::printf("wrote %s  %s\n", p.path.c_str(), p.what.c_str());
    for (const DemoRun &r : runs)
        std::printf("wrote %s/%s/{disp_0,disp_1,flow}/%s_10.png and %s/viz/%s_%s_{flow,disp0,disp0_error,flow_error}.png\n",
                    out.c_str(), r.name, id.c_str(), out.c_str(), id.c_str(), r.name);
    return 0;
}

}  // namespace
}  // namespace lidarflow::cli

LIDARFLOW_COMMAND(demo, "demo", "run the estimator on the built-in synthetic scene and draw the results", lidarflow::cli::run_demo,
                  10);
