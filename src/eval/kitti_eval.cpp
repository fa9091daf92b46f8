// SPDX-License-Identifier: MIT
#include "eval/kitti_eval.hpp"

#include <algorithm>
#include <filesystem>

#include "core/error.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"

namespace lidarflow::eval {
namespace {

namespace fs = std::filesystem;

void require_file(const std::string &path, const std::string &what) {
    require(fs::is_regular_file(path), ErrorCode::Io, "missing " + what + " file " + path);
}

}  // namespace

FrameGroundTruth load_ground_truth(const std::string &kitti_root, const std::string &id) {
    const io::KittiLayout k{kitti_root};
    FrameGroundTruth gt;
    for (const std::string &p : {k.gt_disp0(id, true), k.gt_disp1(id, true), k.gt_flow(id, true)})
        require_file(p, "ground-truth");
    gt.occ = {io::read_disparity_png(k.gt_disp0(id, true)), io::read_disparity_png(k.gt_disp1(id, true)),
              io::read_flow_png(k.gt_flow(id, true))};

    const std::vector<std::string> noc = {k.gt_disp0(id, false), k.gt_disp1(id, false), k.gt_flow(id, false)};
    const auto present = std::count_if(noc.begin(), noc.end(), [](const std::string &p) { return fs::exists(p); });
    if (present == 0) return gt;
    // Some noc maps but not all would silently drop the noc scores: ask for the missing one.
    for (const std::string &p : noc) require_file(p, "ground-truth (noc)");
    gt.noc = {io::read_disparity_png(noc[0]), io::read_disparity_png(noc[1]), io::read_flow_png(noc[2])};
    gt.has_noc = true;
    return gt;
}

Estimate load_estimate(const std::string &est_root, const std::string &id) {
    const io::KittiLayout k{est_root};
    for (const std::string &p : {k.est_disp0(id), k.est_disp1(id), k.est_flow(id)}) require_file(p, "estimate");
    return {io::read_disparity_png(k.est_disp0(id)), io::read_disparity_png(k.est_disp1(id)),
            io::read_flow_png(k.est_flow(id))};
}

DisparityMap load_lidar_seeds(const std::string &lidar_root, const std::string &id) {
    const std::string p = io::KittiLayout{lidar_root}.lidar(id, 0);
    require_file(p, "LiDAR seed");
    return io::read_disparity_png(p);
}

std::vector<std::string> submission_ids(const std::string &est_root) {
    return io::KittiLayout{est_root}.ids_in("disp_0");
}

KittiEvaluation evaluate_kitti(const std::string &kitti_root, const std::string &est_root,
                               const std::vector<std::string> &ids, const EvalOptions &opt,
                               const std::string &lidar_root) {
    require(!ids.empty(), ErrorCode::InvalidArgument, "no frames to evaluate in " + est_root);
    KittiEvaluation out;
    out.options = opt;
    for (const std::string &id : ids) {
        const FrameGroundTruth gt = load_ground_truth(kitti_root, id);
        const Estimate est = load_estimate(est_root, id);
        const DisparityMap seeds = lidar_root.empty() ? DisparityMap() : load_lidar_seeds(lidar_root, id);
        try {
            out.frames.push_back(evaluate_frame(gt, est, opt, lidar_root.empty() ? nullptr : &seeds, id));
        } catch (const Error &e) {
            // evaluate_frame does not know file names: say which frame failed.
            throw Error(e.code(), "frame " + id + ": " + e.what());
        }
    }
    out.summary = summarize(out.frames);
    return out;
}

}  // namespace lidarflow::eval
