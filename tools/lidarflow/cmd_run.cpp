// lidarflow run: the complete estimator on one frame pair of one's own data (four rectified
// images, optional sparse LiDAR maps as KITTI disparity PNGs), written in the KITTI
// submission layout plus pictures.
#include <cstdio>
#include <string>

#include "args.hpp"
#include "commands.hpp"
#include "option_assignments.hpp"
#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/kitti_submission.hpp"
#include "io/output_folder.hpp"
#include "pipeline/estimator.hpp"
#include "viz/disparity_color.hpp"
#include "viz/flow_color.hpp"

namespace lidarflow::cli {
namespace {

SparseLidar read_lidar(const std::string &path, const cv::Size &size, const char *what) {
    const DisparityMap map = io::read_disparity_png(path);
    require(map.size() == size, ErrorCode::SizeMismatch,
            std::string(what) + " " + path + " is " + std::to_string(map.cols) + "x" + std::to_string(map.rows) +
                ", the images are " + std::to_string(size.width) + "x" + std::to_string(size.height));
    return SparseLidar::from_map(map);
}

int run(int argc, char **argv) {
    Args args("run", argc, argv,
              {{"left0", true, "PNG  rectified left image at t0 (reference)"},
               {"right0", true, "PNG  rectified right image at t0"},
               {"left1", true, "PNG  rectified left image at t1"},
               {"right1", true, "PNG  rectified right image at t1"},
               {"calib", true, "FILE KITTI calib_cam_to_cam.txt (the rig; printed with the result)"},
               {"lidar0", true, "PNG  sparse LiDAR D_l^0 in left0 as a KITTI disparity PNG"},
               {"lidar1", true, "PNG  sparse LiDAR D_l^1 in left1 as a KITTI disparity PNG"},
               {"no-lidar", false, "image-only pipeline (ignore --lidar0/--lidar1)"},
               {"stage", true, "S    stop after matching|consistency|sparse|interpolation (default)"},
               {"threads", true, "N    OpenMP threads (default 2)"},
               {"preset", true, "NAME speed/accuracy preset: default | balanced | fast"},
               {"set", true, "K=V,.. any option key of the C ABI (lidarflow.h), after the preset"},
               {"out", true, "DIR  output folder (disp_0/, disp_1/, flow/, viz/)"},
               {"id", true, "ID   frame id of the output files (default 000000)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    const std::string out = args.required("out"), id = args.str("id", "000000");
    // Both name output files: checked before minutes of estimation, not after.
    io::KittiLayout::check_id(id);
    io::prepare_output_folder(out);
    pipeline::FrameInput in;
    in.left0 = io::read_image(args.required("left0"));
    in.right0 = io::read_image(args.required("right0"));
    in.left1 = io::read_image(args.required("left1"));
    in.right1 = io::read_image(args.required("right1"));
    const cv::Size size = in.left0.size();
    for (const cv::Mat *m : {&in.right0, &in.left1, &in.right1})
        require(m->size() == size, ErrorCode::SizeMismatch, "run: the four images must have the same size");
    in.lidar0 = {size.width, size.height, {}};
    in.lidar1 = {size.width, size.height, {}};
    if (args.has("lidar0")) in.lidar0 = read_lidar(args.str("lidar0", ""), size, "--lidar0");
    if (args.has("lidar1")) in.lidar1 = read_lidar(args.str("lidar1", ""), size, "--lidar1");
    if (args.has("calib")) {
        const io::CamToCamCalib calib = io::read_calib_cam_to_cam(args.str("calib", ""));
        std::printf("camera    fx %.2f px, baseline %.4f m\n", calib.camera.fx, calib.camera.baseline);
        in.camera = calib.camera;  // enables the rigid background model of stage 4
    }

    pipeline::EstimatorOptions opt = pipeline::EstimatorOptions::preset(args.str("preset", "default"));
    opt.use_lidar = !args.flag("no-lidar");
    opt.threads = args.integer("threads", 2);
    opt.last_stage = pipeline::parse_stage(args.str("stage", "interpolation"));
    apply_option_assignments(opt, args.list("set"));
    const pipeline::Estimator estimator(opt);
    const pipeline::EstimatorResult r = estimator.run(in);
    const SceneFlowField &f = r.output();

    io::write_submission(out, id, f);
    io::write_image(out + "/viz/" + id + "_flow.png", viz::flow_to_color(io::field_flow(f)));
    io::write_image(out + "/viz/" + id + "_disp0.png", viz::disparity_to_color(io::field_disparity0(f)));
    io::write_image(out + "/viz/" + id + "_disp1.png", viz::disparity_to_color(io::field_disparity1(f)));

    std::printf("input     %dx%d, LiDAR %zu points at t0, %zu at t1%s\n", size.width, size.height,
                in.lidar0.points.size(), in.lidar1.points.size(), opt.use_lidar ? "" : " (ignored: --no-lidar)");
    std::printf("result    stage %s, density %.2f %%\n", pipeline::stage_name(opt.last_stage),
                100.0 * cv::countNonZero(f.valid) / static_cast<double>(f.valid.total()));
    for (const pipeline::StageTime &t : r.timings) std::printf("  %-18s %8.3f s\n", t.name.c_str(), t.seconds);
    std::printf("  %-18s %8.3f s\n", "total", r.total_seconds);
    std::printf("wrote     %s/{disp_0,disp_1,flow}/%s_10.png and %s/viz/\n", out.c_str(), id.c_str(), out.c_str());
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(run, "run", "estimate scene flow for one frame pair of your own images (+ sparse LiDAR)", run, 55);

}  // namespace lidarflow::cli
