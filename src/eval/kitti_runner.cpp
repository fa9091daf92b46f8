// SPDX-License-Identifier: MIT
#include "eval/kitti_runner.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/maps.hpp"
#include "eval/json_report.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/kitti_submission.hpp"
#include "io/output_folder.hpp"
#include "io/result_formats.hpp"
#include "io/velodyne.hpp"
#include "lidar/paper_protocol.hpp"
#include "lidar/velodyne_protocol.hpp"
#include "matching/scene_flow_matcher.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"
#include "viz/flow_color.hpp"
#include "viz/legend.hpp"

namespace lidarflow::eval {

using pipeline::Estimator;
using pipeline::EstimatorOptions;
using pipeline::EstimatorResult;
using pipeline::Stage;
using pipeline::stage_name;

namespace {

namespace fs = std::filesystem;

bool has_ground_truth(const io::KittiLayout &k, const std::string &id) {
    return fs::exists(k.gt_disp0(id)) && fs::exists(k.gt_disp1(id)) && fs::exists(k.gt_flow(id));
}

// Collects the per-frame scores of one table row; rows are created in a fixed order on the
// first frame and filled frame by frame.
class RowTable {
public:
    explicit RowTable(std::vector<ResultRow> &rows) : rows_(rows) {}
    void add(const std::string &group, const std::string &name, FillMode mode,
             const FrameGroundTruth &gt, const SceneFlowField &field, const DisparityMap &seeds,
             const std::string &id) {
        ResultRow *row = nullptr;
        for (ResultRow &r : rows_)
            if (r.group == group && r.name == name) row = &r;
        if (!row) {
            rows_.push_back({group, name, {}});
            row = &rows_.back();
            row->evaluation.options.mode = mode;
        }
        const bool any_seed = cv::countNonZero(seeds >= 0) > 0;
        row->evaluation.frames.push_back(
            evaluate_frame(gt, field, row->evaluation.options, any_seed ? &seeds : nullptr, id));
    }

private:
    std::vector<ResultRow> &rows_;
};

FillMode mode_for(Stage s) {
    return s == Stage::Consistency || s == Stage::Sparse ? FillMode::EstimateOnly : FillMode::Filled;
}

const char *group_of(Stage s) {
    return s == Stage::Matching ? "Matching" : s == Stage::Interpolation ? "Interpolation" : "Consist. Check";
}

void write_viz(const std::string &out, const std::string &id, const SceneFlowField &f,
               const FrameGroundTruth *gt) {
    const std::string dir = out + "/viz/" + id;
    const FlowField flow = io::field_flow(f);
    const DisparityMap d0 = io::field_disparity0(f), d1 = io::field_disparity1(f);
    // Each picture carries its legend (as `viz` writes them), so it reads on its own: the flow
    // wheel at the picture's normalisation, disparity colour bars, the error maps' log scale.
    const viz::FlowColorOptions fo;
    io::write_image(dir + "_flow.png",
                    viz::with_flow_legend(viz::flow_to_color(flow, fo), viz::flow_color_scale(flow, fo), fo.style));
    io::write_image(dir + "_disp0.png",
                    viz::with_disparity_legend(viz::disparity_to_color(d0), viz::disparity_color_scale(d0)));
    io::write_image(dir + "_disp1.png",
                    viz::with_disparity_legend(viz::disparity_to_color(d1), viz::disparity_color_scale(d1)));
    if (!gt) return;
    const GroundTruth &occ = gt->occ;
    const GroundTruth *noc = gt->has_noc ? &gt->noc : nullptr;
    io::write_image(dir + "_disp0_error.png", viz::with_error_legend(viz::disparity_error_image(
                                                  d0, occ.d0, noc ? noc->d0 : DisparityMap())));
    io::write_image(dir + "_disp1_error.png", viz::with_error_legend(viz::disparity_error_image(
                                                  d1, occ.d1, noc ? noc->d1 : DisparityMap())));
    io::write_image(dir + "_flow_error.png",
                    viz::with_error_legend(viz::flow_error_image(flow, occ.flow, noc ? noc->flow : FlowField())));
}

std::string fmt(double v, int prec = 2) {
    if (!std::isfinite(v)) return "-";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*f", prec, v);
    return buf;
}

std::string pad(std::string s, size_t w) {
    if (s.size() < w) s.insert(0, w - s.size(), ' ');
    return s;
}

std::string pad_right(std::string s, size_t w) {
    if (s.size() < w) s.append(w - s.size(), ' ');
    return s;
}

}  // namespace

const char *protocol_name(LidarProtocol p) {
    switch (p) {
    case LidarProtocol::Paper: return "paper";
    case LidarProtocol::Velodyne: return "velodyne";
    case LidarProtocol::None: return "none";
    }
    return "unknown";
}

LidarProtocol parse_protocol(const std::string &name) {
    for (LidarProtocol p : {LidarProtocol::Paper, LidarProtocol::Velodyne, LidarProtocol::None})
        if (name == protocol_name(p)) return p;
    throw Error(ErrorCode::InvalidArgument, "unknown LiDAR protocol '" + name + "' (paper, velodyne, none)");
}

KittiFrame load_kitti_frame(const std::string &root, const std::string &id, const LidarInputOptions &lidar) {
    const io::KittiLayout k{root};
    KittiFrame f;
    f.id = id;
    f.input.left0 = io::read_image(k.left(id, 0));
    f.input.right0 = io::read_image(k.right(id, 0));
    f.input.left1 = io::read_image(k.left(id, 1));
    f.input.right1 = io::read_image(k.right(id, 1));
    const cv::Size size = f.input.left0.size();
    f.input.lidar0 = {size.width, size.height, {}};
    f.input.lidar1 = {size.width, size.height, {}};
    // The rig is optional for the estimator (calibration-free fallback), so a folder without
    // calib_cam_to_cam still runs; a file that is there but broken is an error.
    if (std::filesystem::exists(k.calib_cam_to_cam(id)))
        f.input.camera = io::read_calib_cam_to_cam(k.calib_cam_to_cam(id)).camera;
    if (lidar.protocol == LidarProtocol::Paper) {
        lidar::PaperProtocolOptions po;
        po.target_points = lidar.points;
        po.phase = lidar::placement_phase(lidar.placement);
        lidar::PaperSamples s = lidar::sample_paper_protocol(io::read_disparity_png(k.gt_disp0(id)),
                                                             io::read_disparity_png(k.gt_disp1(id)),
                                                             io::read_flow_png(k.gt_flow(id)), po);
        f.input.lidar0 = std::move(s.d0);
        f.input.lidar1 = std::move(s.d1);
    } else if (lidar.protocol == LidarProtocol::Velodyne) {
        lidar::VelodyneProtocolOptions vo;
        vo.target_points = lidar.points;
        vo.beams = lidar.beams;
        const io::CamToCamCalib calib = io::read_calib_cam_to_cam(k.calib_cam_to_cam(id));
        const cv::Matx44d velo_to_cam = io::read_calib_velo_to_cam(k.calib_velo_to_cam(id));
        f.input.lidar0 =
            lidar::sample_velodyne_protocol(io::read_velodyne_bin(k.velodyne(id)), calib, velo_to_cam, size, vo).d0;
        // Without a t1 scan D1 stays empty and stage 4 works from D0 alone, as the estimator
        // allows; the caller sees it as 0 points at t1.
        if (std::filesystem::exists(k.velodyne_t1(id)))
            f.input.lidar1 =
                lidar::sample_velodyne_protocol(io::read_velodyne_bin(k.velodyne_t1(id)), calib, velo_to_cam, size, vo)
                    .d0;
    }
    return f;
}

namespace {

// KITTI's obj_map of a frame when the layout has one (the shared frames do not; the full
// training set does), else empty.
cv::Mat1b load_objects(const io::KittiLayout &k, const std::string &id, const cv::Size &size) {
    const std::string path = k.obj_map(id);
    if (!std::filesystem::exists(path)) return {};
    const cv::Mat m = io::read_image(path);
    require(m.type() == CV_8UC1 && m.size() == size, ErrorCode::Format,
            path + ": an object map must be an 8-bit gray PNG of the image's size");
    return m;
}

}  // namespace

KittiRunReport run_kitti(const KittiRunOptions &o, const Progress &progress) {
    const io::KittiLayout k{o.root};
    const std::vector<std::string> ids = o.ids.empty() ? k.frame_ids() : o.ids;
    require(!ids.empty(), ErrorCode::InvalidArgument, "kitti: no frames in " + o.root);
    // Bad ids and an unwritable output folder fail now, not after the frames before them.
    for (const std::string &id : ids) io::KittiLayout::check_id(id);
    if (!o.out.empty()) io::prepare_output_folder(o.out);

    EstimatorOptions main_opt = o.estimator;
    main_opt.use_lidar = o.lidar.protocol != LidarProtocol::None && o.estimator.use_lidar;
    const Stage last = main_opt.last_stage;
    main_opt.keep_stage_fields = o.ablation;  // the Table I rows read every stage's field
    const Estimator estimator(main_opt);
    // The image-only pipeline (the SceneFlowFields-style comparison rows).
    EstimatorOptions image_opt = main_opt;
    image_opt.use_lidar = false;
    const bool image_rows = o.ablation && main_opt.use_lidar;
    interpolation::InterpolationOptions interp_only = main_opt.interpolation;
    interp_only.use_lidar = false;
    interp_only.num_threads = main_opt.threads;

    KittiRunReport rep;
    RowTable table(rep.rows);
    const std::string main_name = main_opt.use_lidar ? "LiDAR-Flow" : "image-only";
    for (size_t i = 0; i < ids.size(); ++i) {
        const std::string &id = ids[i];
        if (progress) progress(i, ids.size(), id + ": loading");
        const KittiFrame frame = load_kitti_frame(o.root, id, o.lidar);
        // Table II scores the D_l^0 the estimator used: after its visibility filter.
        const DisparityMap seeds = lidar_in_use(main_opt, frame.input.lidar0).to_map();
        const bool scored = has_ground_truth(k, id);
        FrameGroundTruth gt;
        if (scored) gt = load_ground_truth(o.root, id);

        if (progress) progress(i, ids.size(), id + ": " + main_name);
        const EstimatorResult r = estimator.run(frame.input);
        rep.timings.push_back({id, frame.input.lidar0.points.size(), frame.input.lidar1.points.size(), r.timings,
                               r.total_seconds});
        if (!o.out.empty()) {
            io::write_submission(o.out, id, r.output());
            io::write_npy(o.out + "/confidence/" + id + "_10.npy", io::confidence_map(r.output()));
            if (o.write_viz) write_viz(o.out, id, r.output(), scored ? &gt : nullptr);
        }
        if (!scored) continue;
        if (!o.ablation) {
            table.add(group_of(last), main_name, mode_for(last), gt, r.output(), seeds, id);
            continue;
        }

        // Table I: every stage up to `last`, LiDAR variants and the image-only comparison.
        EstimatorResult img;
        if (image_rows) {
            if (progress) progress(i, ids.size(), id + ": image-only");
            img = Estimator(image_opt).run(frame.input);
        }
        const DisparityMap no_seeds = filled(seeds.size(), kInvalidDisparity);
        if (main_opt.use_lidar) {
            using matching::MatchVariant;
            table.add("Matching", "im-only", FillMode::Filled, gt, img.forward, seeds, id);
            for (MatchVariant v : {MatchVariant::ImLidar, MatchVariant::ImLidarWin, MatchVariant::ImLidarWinConst1}) {
                if (progress) progress(i, ids.size(), id + ": matching " + matching::variant_name(v));
                // The main run's settings (preset, scale) with this row's LiDAR switches.
                EstimatorOptions vo = main_opt;
                vo.matching = main_opt.matching.with_variant(v);
                vo.last_stage = Stage::Matching;
                table.add("Matching", matching::variant_name(v), FillMode::Filled, gt,
                          Estimator(vo).run(frame.input).forward, seeds, id);
            }
        }
        table.add("Matching", main_name, FillMode::Filled, gt, r.forward, seeds, id);
        if (last == Stage::Matching) continue;
        table.add("Consist. Check", main_opt.use_lidar ? "Disp+LiDAR" : "disp", FillMode::EstimateOnly, gt,
                  r.after_sgm, seeds, id);
        table.add("Consist. Check", main_opt.use_lidar ? "disp+LiDAR & backward+LiDAR" : "disp & backward",
                  FillMode::EstimateOnly, gt, r.after_fb, seeds, id);
        if (image_rows)
            table.add("Consist. Check", "image-only", FillMode::EstimateOnly, gt, img.after_fb, no_seeds, id);
        if (last == Stage::Consistency) continue;
        table.add("Interpolation", main_opt.use_lidar ? "Spars+LiDAR" : "Spars", FillMode::EstimateOnly, gt,
                  r.sparse, seeds, id);
        if (last == Stage::Sparse) continue;
        if (main_opt.use_lidar) {
            if (progress) progress(i, ids.size(), id + ": interp-only");
            const SceneFlowField dense_only =
                interpolation::RobustInterpolator(interp_only)
                    .run(r.sparse, frame.input.lidar0, frame.input.left0, DisparityMap(), frame.input.camera)
                    .dense;
            table.add("Interpolation", "Spars+LiDAR & Interp-only", FillMode::Filled, gt, dense_only, seeds, id);
        }
        table.add("Interpolation", main_opt.use_lidar ? "LiDAR-Flow (Spars+LiDAR & Interp+LiDAR)" : "image-only",
                  FillMode::Filled, gt, r.dense, seeds, id);
        if (image_rows) table.add("Interpolation", "image-only", FillMode::Filled, gt, img.dense, seeds, id);

        const cv::Mat1b objects = load_objects(k, id, frame.input.left0.size());
        const auto breakdown = [&](const SceneFlowField &dense) {
            return outlier_breakdown(gt, estimate_from_scene_flow(dense),
                                           cv::countNonZero(seeds >= 0) > 0 ? &seeds : nullptr,
                                           objects.empty() ? nullptr : &objects);
        };
        rep.outlier_regions += breakdown(r.dense);
        if (image_rows) rep.outlier_regions_image_only += breakdown(img.dense);
    }
    for (ResultRow &row : rep.rows) row.evaluation.summary = summarize(row.evaluation.frames);
    for (size_t i = 0; i < rep.rows.size(); ++i)
        if (rep.rows[i].name.rfind(main_name, 0) == 0 && rep.rows[i].group == group_of(last)) rep.main_row = i;
    if (!o.out.empty()) {
        std::ofstream f(o.out + "/report.json");
        f << report_json(o, rep);
        f.close();
        require(!f.fail(), ErrorCode::Io, "cannot write " + o.out + "/report.json");
    }
    return rep;
}

std::string format_report(const KittiRunReport &rep) {
    std::ostringstream s;
    if (rep.rows.empty()) return "no frame had ground truth: nothing scored\n";
    const size_t frames = rep.rows.front().evaluation.frames.size();
    s << "Table I (occ ground truth; mean over " << frames
      << " frame(s); sparse rows scored on their own pixels, dense rows hole-filled as the devkit does)\n";
    s << pad_right("", 16) << pad_right("", 42) << "   ------ EPE [px] ------   -------- outliers [%] --------   density\n";
    s << pad_right("stage", 16) << pad_right("variant", 42) << pad("D0", 8) << pad("D1", 8) << pad("Fl", 8) << "   "
      << pad("D0", 7) << pad("D1", 7) << pad("Fl", 7) << pad("SF", 7) << "   " << pad("[%]", 7) << "\n";
    std::string group;
    for (const ResultRow &row : rep.rows) {
        const ComponentMeans &m = row.evaluation.summary.mean_dense.occ;
        s << pad_right(row.group == group ? "" : row.group, 16) << pad_right(row.name, 42) << pad(fmt(m.d0.epe), 8)
          << pad(fmt(m.d1.epe), 8) << pad(fmt(m.fl.epe), 8) << "   " << pad(fmt(m.d0.outlier_pct), 7)
          << pad(fmt(m.d1.outlier_pct), 7) << pad(fmt(m.fl.outlier_pct), 7) << pad(fmt(m.sf.outlier_pct), 7) << "   "
          << pad(fmt(m.sf.density_pct), 7) << "\n";
        group = row.group;
    }
    s << "\nSF outliers [%] per frame (occ / noc)\n" << pad_right("variant", 58);
    for (const FrameScore &f : rep.rows.front().evaluation.frames) s << pad(f.id, 16);
    s << pad("pooled", 16) << "\n";
    for (const ResultRow &row : rep.rows) {
        s << pad_right(row.group + ": " + row.name, 58);
        auto cell = [](const RegionScores &r) {
            return fmt(r.occ.sf.outlier_pct()) + " / " + (r.has_noc ? fmt(r.noc.sf.outlier_pct()) : "-");
        };
        for (const FrameScore &f : row.evaluation.frames) s << pad(cell(f.dense), 16);
        s << pad(cell(row.evaluation.summary.pooled.dense), 16) << "\n";
    }
    bool header = false;
    for (const ResultRow &row : rep.rows) {
        const Summary &sm = row.evaluation.summary;
        if (row.group != "Interpolation" || !sm.pooled.has_lidar) continue;
        if (!header) {
            s << "\nTable II (final SF outliers [%], occ, mean over frames)\n" << pad_right("variant", 42)
              << pad("seeds", 9) << pad("window", 9) << pad("dense", 9) << pad("#seeds", 9) << pad("#window", 9)
              << "\n";
            header = true;
        }
        s << pad_right(row.name, 42) << pad(fmt(sm.mean_seeds.occ.sf.outlier_pct), 9)
          << pad(fmt(sm.mean_window.occ.sf.outlier_pct), 9) << pad(fmt(sm.mean_dense.occ.sf.outlier_pct), 9)
          << pad(fmt(double(sm.pooled.seeds.occ.sf.n_total) / row.evaluation.frames.size(), 0), 9)
          << pad(fmt(double(sm.pooled.window.occ.sf.n_total) / row.evaluation.frames.size(), 0), 9) << "\n";
    }
    if (!rep.outlier_regions.regions.empty())
        s << "\n"
          << format_outlier_breakdown(rep.outlier_regions,
                                            rep.outlier_regions_image_only.regions.empty()
                                                ? nullptr
                                                : &rep.outlier_regions_image_only,
                                            "image-only");
    return s.str();
}

std::string report_json(const KittiRunOptions &o, const KittiRunReport &rep) {
    std::ostringstream s;
    s.precision(9);
    s << "{\n  \"format\": \"lidarflow-kitti/1\",\n  \"lidar\": \"" << protocol_name(o.lidar.protocol)
      << "\",\n  \"lidar_points\": " << o.lidar.points << ",\n  \"stage\": \"" << stage_name(o.estimator.last_stage)
      << "\",\n  \"threads\": " << o.estimator.threads << ",\n  \"frames\": [";
    for (size_t i = 0; i < rep.timings.size(); ++i) {
        const FrameTimings &t = rep.timings[i];
        s << (i ? "," : "") << "\n    {\"id\": \"" << t.id << "\", \"lidar0_points\": " << t.lidar0_points
          << ", \"lidar1_points\": " << t.lidar1_points << ", \"total_seconds\": " << t.total_seconds
          << ", \"seconds\": {";
        for (size_t j = 0; j < t.stages.size(); ++j)
            s << (j ? ", " : "") << "\"" << t.stages[j].name << "\": " << t.stages[j].seconds;
        s << "}}";
    }
    s << "\n  ],\n  \"main_row\": " << rep.main_row << ",\n  \"rows\": [";
    for (size_t i = 0; i < rep.rows.size(); ++i)
        s << (i ? "," : "") << "\n    {\"group\": \"" << rep.rows[i].group << "\", \"name\": \"" << rep.rows[i].name
          << "\", \"evaluation\": " << to_json(rep.rows[i].evaluation) << "}";
    s << "\n  ]";
    if (!rep.outlier_regions.regions.empty()) s << ",\n  \"outlier_regions\": " << to_json(rep.outlier_regions);
    if (!rep.outlier_regions_image_only.regions.empty())
        s << ",\n  \"outlier_regions_image_only\": " << to_json(rep.outlier_regions_image_only);
    s << "\n}\n";
    return s.str();
}

}  // namespace lidarflow::eval
