// SPDX-License-Identifier: MIT
// lidarflow sample-lidar: writes the sparse LiDAR inputs of KITTI frames as disparity PNGs,
// OUT/lidar_0/ID_10.png (in I_l^0) and OUT/lidar_1/ID_10.png (in I_l^1).
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/output_folder.hpp"
#include "io/velodyne.hpp"
#include "lidar/paper_protocol.hpp"
#include "lidar/velodyne_protocol.hpp"

namespace lidarflow::cli {
namespace {

struct FrameRow {
    std::string id;
    std::size_t projected = 0;  // velodyne only
    std::size_t n0 = 0, n1 = 0;
    int step = 0;
};

int run_sample_lidar(int argc, char **argv) {
    Args args("sample-lidar", argc, argv,
              {{"root", true, "DIR   KITTI training folder (image_2/, disp_occ_0/, velodyne/, ...)"},
               {"ids", true, "A,B   frame ids (default: every frame in DIR)"},
               {"protocol", true, "P     paper (from ground truth, t0 and t1) or velodyne (real scan, t0 only)"},
               {"points", true, "N     points per map: paper default 88; velodyne default all"},
               {"beams", true, "K     velodyne only: keep K evenly spaced beams"},
               {"step", true, "S     fixed grid step instead of searching the one closest to N"},
               {"out", true, "OUT   output folder (lidar_0/, lidar_1/)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    const io::KittiLayout in{args.required("root")};
    const io::KittiLayout out{args.required("out")};
    const std::string protocol = args.required("protocol");
    require(protocol == "paper" || protocol == "velodyne", ErrorCode::InvalidArgument,
            "sample-lidar: --protocol must be paper or velodyne, got '" + protocol + "'");
    const bool paper = protocol == "paper";
    const int points = args.integer("points", paper ? 88 : 0);
    const int beams = args.integer("beams", 0);
    const int step = args.integer("step", 0);
    require(points >= (paper ? 1 : 0), ErrorCode::InvalidArgument,
            paper ? "sample-lidar: --points must be >= 1" : "sample-lidar: --points must be >= 0 (0 = all)");
    require(!paper || !args.has("beams"), ErrorCode::InvalidArgument,
            "sample-lidar: --beams applies to the velodyne protocol only");
    require(!args.has("beams") || beams >= 1, ErrorCode::InvalidArgument, "sample-lidar: --beams must be >= 1");
    require(!args.has("step") || step >= 5, ErrorCode::InvalidArgument, "sample-lidar: --step must be >= 5 (the window)");
    std::vector<std::string> ids = args.list("ids");
    if (ids.empty()) ids = in.frame_ids();
    require(!ids.empty(), ErrorCode::InvalidArgument, "sample-lidar: no frames in " + in.root);
    for (const std::string &id : ids) io::KittiLayout::check_id(id);
    io::prepare_output_folder(out.root);
    inputs_begin();

    std::vector<FrameRow> rows;
    for (const std::string &id : ids) {
        FrameRow row{id};
        if (paper) {
            lidar::PaperProtocolOptions opt;
            opt.target_points = points;
            opt.step = step;
            const lidar::PaperSamples s = lidar::sample_paper_protocol(
                io::read_disparity_png(in.gt_disp0(id)), io::read_disparity_png(in.gt_disp1(id)),
                io::read_flow_png(in.gt_flow(id)), opt);
            io::write_disparity_png(out.lidar(id, 0), s.d0.to_map());
            io::write_disparity_png(out.lidar(id, 1), s.d1.to_map());
            row.n0 = s.d0.points.size();
            row.n1 = s.d1.points.size();
            row.step = s.step;
        } else {
            lidar::VelodyneProtocolOptions opt;
            opt.target_points = points;
            opt.beams = beams;
            opt.step = step;
            const cv::Mat left = io::read_image(in.left(id, 0));
            const lidar::VelodyneSamples s = lidar::sample_velodyne_protocol(
                io::read_velodyne_bin(in.velodyne(id)), io::read_calib_cam_to_cam(in.calib_cam_to_cam(id)),
                io::read_calib_velo_to_cam(in.calib_velo_to_cam(id)), left.size(), opt);
            io::write_disparity_png(out.lidar(id, 0), s.d0.to_map());
            io::write_disparity_png(out.lidar(id, 1), s.d1.to_map());
            row.projected = s.projected;
            row.n0 = s.d0.points.size();
            row.n1 = 0;
            row.step = s.step;
        }
        rows.push_back(row);
    }

    std::string mode;
    if (paper)
        mode = step ? std::string("points on the grid") : "N = " + std::to_string(points) + " per map";
    else
        mode = std::string("beams ") + (beams ? std::to_string(beams) : "all") + ", points " +
               (step ? std::string("on the grid") : points ? "~" + std::to_string(points) : std::string("all"));
    if (paper || points || step)
        mode += step ? ", 5x5 windows, fixed step" : ", 5x5 windows, step searched per frame";
    std::printf("sample-lidar: protocol %s, %s\n", protocol.c_str(), mode.c_str());
    std::printf("%-8s %9s %8s %8s %6s\n", "id", "projected", "lidar_0", "lidar_1", "step");
    double m_proj = 0, m0 = 0, m1 = 0, m_step = 0;
    const double n = static_cast<double>(rows.size());
    for (const FrameRow &r : rows) {
        std::printf("%-8s %9s %8zu %8zu %6s\n", r.id.c_str(), paper ? "-" : std::to_string(r.projected).c_str(), r.n0,
                    r.n1, r.step ? std::to_string(r.step).c_str() : "-");
        m_proj += static_cast<double>(r.projected) / n;
        m0 += static_cast<double>(r.n0) / n;
        m1 += static_cast<double>(r.n1) / n;
        m_step += r.step / n;
    }
    char step_text[32] = "-", proj_text[32] = "-";
    if (m_step > 0) std::snprintf(step_text, sizeof step_text, "%.1f", m_step);
    if (!paper) std::snprintf(proj_text, sizeof proj_text, "%.1f", m_proj);
    std::printf("%-8s %9s %8.1f %8.1f %6s\n", "mean", proj_text, m0, m1, step_text);
    if (!paper)
        std::printf("lidar_1 maps are all-invalid: the velodyne protocol has a scan at t0 only\n");
    std::printf("wrote %zu frame(s) to %s/lidar_0 and %s/lidar_1\n", rows.size(), out.root.c_str(),
                out.root.c_str());
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(sample_lidar, "sample-lidar", "sparse LiDAR inputs of KITTI frames (paper or velodyne protocol)",
                  run_sample_lidar, 30);

}  // namespace lidarflow::cli
