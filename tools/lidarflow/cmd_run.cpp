// SPDX-License-Identifier: MIT
// lidarflow run: the complete estimator on one frame pair of one's own data (four images,
// rectified or with the calibration of a raw rig to rectify them; optional sparse LiDAR as KITTI disparity PNGs or raw Velodyne scans), written in the
// KITTI submission layout or float formats, plus pictures and optionally a point cloud.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "ego_matrix.hpp"
#include "log.hpp"
#include "result_files.hpp"
#include "rig_args.hpp"
#include "core/error.hpp"
#include "core/gray.hpp"
#include "core/size_text.hpp"
#include "io/calib.hpp"
#include "io/image_file.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/kitti_submission.hpp"
#include "io/output_folder.hpp"
#include "io/point_cloud.hpp"
#include "io/rectify.hpp"
#include "io/result_formats.hpp"
#include "io/velodyne.hpp"
#include "lidar/velodyne_protocol.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/option_assignments.hpp"
#include "viz/disparity_color.hpp"
#include "viz/flow_color.hpp"
#include "viz/legend.hpp"

namespace lidarflow::cli {
namespace {

double rotation_degrees(const cv::Matx44d &T) {
    const double c = std::clamp((T(0, 0) + T(1, 1) + T(2, 2) - 1) / 2, -1.0, 1.0);
    return std::acos(c) * 180 / CV_PI;
}

SparseLidar read_lidar(const std::string &path, const cv::Size &size, const char *what) {
    const DisparityMap map = io::read_disparity_png(path);
    require(map.size() == size, ErrorCode::SizeMismatch,
            std::string(what) + " " + path + " is " + size_text(map.size()) + ", the images are " + size_text(size));
    return SparseLidar::from_map(map);
}

// A raw scan projected into the left image of its own time (the t1 scan lands in I_l^1, which is
// where the estimator takes D_l^1), with the whole scan kept: thinning is a protocol choice of
// `kitti` / `sample-lidar`, not of one's own data.
SparseLidar project_scan(const std::string &path, const io::CamToCamCalib &calib, const cv::Matx44d &velo_to_cam,
                         const cv::Size &size, const char *what) {
    const io::VelodyneScan scan = io::read_velodyne_bin(path);
    SparseLidar l = lidar::sample_velodyne_protocol(scan, calib, velo_to_cam, size).d0;
    note("run: %s %s: %zu points, %zu in the image%s\n", what, path.c_str(), scan.points.size(),
                 l.points.size(),
                 scan.dropped_nonfinite ? (", " + std::to_string(scan.dropped_nonfinite) + " non-finite dropped").c_str()
                                        : "");
    return l;
}

const char *const kImageNames[4] = {"left0", "right0", "left1", "right1"};

// Colour and gray images together (a colour left camera, a monochrome right one) are all matched
// in gray, as the estimator matches intensities; said before estimating, not found out after.
void match_formats(cv::Mat *const images[4]) {
    std::string colour, gray;
    for (int i = 0; i < 4; ++i) {
        std::string &list = images[i]->channels() == 1 ? gray : colour;
        list += (list.empty() ? "--" : ", --") + std::string(kImageNames[i]);
    }
    if (colour.empty() || gray.empty()) return;
    note("run: %s in colour but %s in gray: all four are matched in gray\n", colour.c_str(), gray.c_str());
    for (int i = 0; i < 4; ++i)
        if (images[i]->channels() != 1) *images[i] = gray8(*images[i]).clone();
}

std::vector<OptionSpec> run_options() {
    std::vector<OptionSpec> spec = {
        {"left0", true, "IMG  left image at t0 (reference); 8-bit gray or colour PNG, JPEG, BMP or PGM/PPM"},
        {"right0", true, "IMG  right image at t0"},
        {"left1", true, "IMG  left image at t1"},
        {"right1", true, "IMG  right image at t1"}};
    for (OptionSpec &o : rig_option_specs()) spec.push_back(o);
    return spec;
}

int run(int argc, char **argv) {
    std::vector<OptionSpec> spec = run_options();
    spec.insert(spec.end(),
              {{"lidar0", true, "PNG  sparse LiDAR D_l^0 in left0 (rectified) as a KITTI disparity PNG"},
               {"lidar1", true, "PNG  sparse LiDAR D_l^1 in left1 as a KITTI disparity PNG"},
               {"velo0", true, "BIN  raw Velodyne scan at t0 (KITTI .bin; instead of --lidar0)"},
               {"velo1", true, "BIN  raw Velodyne scan at t1 (instead of --lidar1)"},
               {"calib-velo", true, "FILE KITTI calib_velo_to_cam.txt (Velodyne -> camera 0), for --velo0/1"},
               {"no-lidar", false, "image-only pipeline (ignore the LiDAR inputs)"},
               {"stage", true, "S    stop after matching|consistency|sparse|interpolation (default)"},
               {"threads", true, "N    OpenMP threads (default: every usable CPU, fewer while others are busy)"},
               {"preset", true, "NAME speed/accuracy preset: default | paper | balanced | fast | realtime"},
               {"set", true, "K=V,.. any option key of the C ABI (lidarflow.h), after the preset"},
               {"out", true, "DIR  output folder (disp_0/, disp_1/, flow/, viz/)"},
               {"id", true, "NAME output file name (default: left0's, 000002_10.png -> 000002); 6 digits write ID_10.EXT as KITTI does, other names NAME.EXT"},
               {"format", true, "F,.. result files: kitti (16-bit PNG, default) | flo | pfm | npy"},
               {"points", true, "PLY  also write the 3-D points at t0 with their motion and colour"}});
    Args args("run", argc, argv, spec);
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    // Every missing argument is reported before any file is read.
    const std::string paths[4] = {args.required("left0"), args.required("right0"), args.required("left1"),
                                  args.required("right1")};
    const std::string out = args.required("out");
    const std::string id = args.has("id") ? args.str("id", "") : io::output_name_from_path(args.required("left0"));
    // Both name output files: checked before minutes of estimation, not after.
    io::check_output_name(id);
    io::prepare_output_folder(out);
    const std::vector<io::ResultFormat> formats =
        parse_formats(args.has("format") ? args.list("format") : std::vector<std::string>{"kitti"}, "run");
    require(!(args.has("lidar0") && args.has("velo0")), ErrorCode::InvalidArgument,
            "run: give --lidar0 or --velo0, not both");
    require(!(args.has("lidar1") && args.has("velo1")), ErrorCode::InvalidArgument,
            "run: give --lidar1 or --velo1, not both");
    const bool velodyne = args.has("velo0") || args.has("velo1");
    const std::optional<io::Rig> rig = rig_from_args(args, "run");
    require(!velodyne || (rig && args.has("calib-velo")), ErrorCode::InvalidArgument,
            "run: --velo0/--velo1 need --calib (or --fx ...) and --calib-velo (calib_velo_to_cam.txt)");
    require(velodyne || !args.has("calib-velo"), ErrorCode::InvalidArgument,
            "run: --calib-velo is only used with --velo0/--velo1");
    require(!args.has("points") || rig, ErrorCode::InvalidArgument,
            "run: --points needs --calib (or --fx ...): metric 3-D points come from the rig's focal length and "
            "baseline");
    pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(args.str("preset", "default"));
    opt.use_lidar = !args.flag("no-lidar");
    opt.threads = args.integer("threads", opt.threads);
    opt.last_stage = pipeline::parse_stage(args.str("stage", "interpolation"));
    pipeline::apply_option_assignments(opt, args.list("set"));
    const pipeline::Estimator estimator(opt);  // checks the options before any file is read
    inputs_begin();

    detail("run: preset %s, %d thread(s), up to stage %s, LiDAR %s, output name %s\n",
           args.str("preset", "default").c_str(), opt.threads, pipeline::stage_name(opt.last_stage),
           opt.use_lidar ? "used" : "ignored", id.c_str());
    note("run: reading the images\n");
    const Stopwatch reading;
    pipeline::FrameInput in;
    cv::Mat *images[4] = {&in.left0, &in.right0, &in.left1, &in.right1};
    for (int i = 0; i < 4; ++i) *images[i] = io::read_any_image(paths[i]);
    const cv::Size size = in.left0.size();
    for (int i = 1; i < 4; ++i)
        require(images[i]->size() == size, ErrorCode::SizeMismatch, [&] {
            return "run: --" + std::string(kImageNames[i]) + " is " + size_text(images[i]->size()) + " but --left0 is " +
                   size_text(size) + ": the four images must have the same size";
        });
    match_formats(images);
    double rectify_seconds = 0;
    if (rig) {
        check_image_size(*rig, size, args.flag("strict"), "run");
        if (rig->rectify) {
            const Stopwatch rectifying;
            const io::Rectifier rectifier(*rig, size);
            rectifier.apply(in.left0, in.right0, in.left0, in.right0);
            rectifier.apply(in.left1, in.right1, in.left1, in.right1);
            rectify_seconds = rectifying.seconds();
        }
    }
    in.lidar0 = {size.width, size.height, {}};
    in.lidar1 = {size.width, size.height, {}};
    if (args.has("lidar0")) in.lidar0 = read_lidar(args.str("lidar0", ""), size, "--lidar0");
    if (args.has("lidar1")) in.lidar1 = read_lidar(args.str("lidar1", ""), size, "--lidar1");
    if (rig) {
        const io::CamToCamCalib &calib = rig->rect;
        std::printf("camera    fx %.2f px, baseline %.4f m%s\n", calib.camera.fx, calib.camera.baseline,
                    rig->rectify ? ", raw images rectified: results in the rectified left camera" : "");
        in.camera = calib.camera;  // enables the rigid background model of stage 4
        in.calibration_size = calib.image_size;  // the input quality's size check
        if (velodyne) {
            const cv::Matx44d velo_to_cam = io::read_calib_velo_to_cam(args.str("calib-velo", ""));
            if (args.has("velo0"))
                in.lidar0 = project_scan(args.str("velo0", ""), calib, velo_to_cam, size, "--velo0");
            if (args.has("velo1"))
                in.lidar1 = project_scan(args.str("velo1", ""), calib, velo_to_cam, size, "--velo1");
        }
    }

    detail("run: inputs read in %s\n", format_duration(reading.seconds()).c_str());
    note("run: estimating (%dx%d, up to stage %s)\n", size.width, size.height, pipeline::stage_name(opt.last_stage));
    const pipeline::EstimatorResult r = estimator.run(in);
    const SceneFlowField &f = r.output();

    note("run: writing %s\n", out.c_str());
    const Stopwatch writing;
    const std::vector<std::string> written = write_result_files(out, id, f, formats);
    // Pictures with their legends, as `viz` draws them; both disparity maps on one scale.
    {
        const FlowField flow = io::field_flow(f);
        const DisparityMap d0 = io::field_disparity0(f), d1 = io::field_disparity1(f);
        const viz::FlowColorOptions fo;
        io::write_image(out + "/viz/" + id + "_flow.png",
                        viz::with_flow_legend(viz::flow_to_color(flow, fo), viz::flow_color_scale(flow, fo), fo.style));
        const double scale = std::max(viz::disparity_color_scale(d0), viz::disparity_color_scale(d1));
        const auto fscale = static_cast<float>(scale);
        io::write_image(out + "/viz/" + id + "_disp0.png",
                        viz::with_disparity_legend(viz::disparity_to_color(d0, fscale), scale));
        io::write_image(out + "/viz/" + id + "_disp1.png",
                        viz::with_disparity_legend(viz::disparity_to_color(d1, fscale), scale));
    }
    detail("run: results and pictures written in %s\n", format_duration(writing.seconds()).c_str());
    size_t cloud = 0;
    const cv::Matx44d ego = ego_matrix(r.ego);
    if (args.has("points")) {
        const std::vector<io::CloudPoint> pts =
            io::scene_points(f, in.camera, in.left0, r.ego_state == pipeline::EgoState::Ok ? &ego : nullptr);
        io::write_ply(args.str("points", ""), pts,
                      rig->rectify ? "camera rectified by lidarflow from raw images (distortion removed, rectifying "
                                     "rotation applied); fx " + std::to_string(in.camera.fx) + " baseline " +
                                         std::to_string(in.camera.baseline)
                                   : "");
        cloud = pts.size();
    }

    std::printf("input     %dx%d, LiDAR %zu points at t0, %zu at t1%s\n", size.width, size.height,
                in.lidar0.points.size(), in.lidar1.points.size(), opt.use_lidar ? "" : " (ignored: --no-lidar)");
    std::printf("result    stage %s, density %.2f %%\n", pipeline::stage_name(opt.last_stage),
                100.0 * cv::countNonZero(f.valid) / static_cast<double>(f.valid.total()));
    if (rig && rig->rectify) std::printf("  %-18s %8.3f s (both pairs)\n", "rectify", rectify_seconds);
    for (const pipeline::StageTime &t : r.timings) std::printf("  %-18s %8.3f s\n", t.name.c_str(), t.seconds);
    std::printf("  %-18s %8.3f s\n", "total", r.total_seconds);
    if (r.ego_state == pipeline::EgoState::Ok)
        std::printf("ego       T t = (%.3f, %.3f, %.3f) m, rotation %.3f deg, %d of %d matches\n", ego(0, 3), ego(1, 3),
                    ego(2, 3), rotation_degrees(ego), r.ego.inliers, r.ego.candidates);
    else
        std::printf("ego       %s\n", pipeline::ego_state_text(r.ego_state));
    std::printf("quality: %s\n", r.quality.summary().c_str());
    for (const std::string &w : written) std::printf("wrote     %s\n", w.c_str());
    std::printf("wrote     %s/viz/%s_{flow,disp0,disp1}.png\n", out.c_str(), id.c_str());
    if (args.has("points"))
        std::printf("wrote     %s: %zu points (x y z, dx dy dz [m], red green blue%s)\n",
                    args.str("points", "").c_str(), cloud,
                    r.ego_state == pipeline::EgoState::Ok ? ", omx omy omz [m]" : "");
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(run, "run", "estimate scene flow for one frame pair of your own images (+ sparse LiDAR)", run, 55);

}  // namespace lidarflow::cli
