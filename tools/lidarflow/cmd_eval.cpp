// SPDX-License-Identifier: MIT
// lidarflow eval: KITTI Scene Flow 2015 scores of a submission folder, as the official devkit
// counts them, with the paper's Table II split when the LiDAR seed maps are given.
#include <cstdio>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "eval/json_report.hpp"
#include "eval/kitti_eval.hpp"
#include "eval/sparsification.hpp"
#include "eval/text_report.hpp"
#include "io/kitti_layout.hpp"

namespace {

int run_eval(int argc, char **argv) {
    using namespace lidarflow;
    cli::Args args("eval", argc, argv,
                   {{"root", true, "DIR  KITTI training folder with the ground truth (disp_occ_0, ...)"},
                    {"est", true, "DIR  submission folder with disp_0/, disp_1/, flow/ (NNNNNN_10.png)"},
                    {"ids", true, "A,B  frames to score (default: every disp_0/*_10.png in --est)"},
                    {"json", true, "FILE  also write the results as JSON"},
                    {"lidar", true, "DIR  folder with lidar_0/ID_10.png seed maps: adds Table II"},
                    {"mode", true, "filled|est-only  devkit hole filling (default) or valid pixels only"},
                    {"window", true, "N  support window side for Table II (odd, default 15)"},
                    {"confidence", true,
                     "DIR  folder with confidence/ID_10.npy (or .pfm) maps: adds each frame's sparsification curve"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    const std::string root = args.required("root");
    const std::string est = args.required("est");
    eval::EvalOptions opt;
    const std::string mode = args.str("mode", "filled");
    require(mode == "filled" || mode == "est-only", ErrorCode::InvalidArgument,
            "eval: --mode must be 'filled' or 'est-only', got '" + mode + "'");
    opt.mode = mode == "filled" ? eval::FillMode::Filled : eval::FillMode::EstimateOnly;
    opt.window = args.integer("window", 15);
    require(opt.window >= 1 && opt.window % 2 == 1, ErrorCode::InvalidArgument,
            "eval: --window must be odd and >= 1, got " + std::to_string(opt.window));

    std::vector<std::string> ids = args.list("ids");
    if (ids.empty()) ids = eval::submission_ids(est);
    require(!ids.empty(), ErrorCode::InvalidArgument, "eval: no disp_0/*_10.png frames in " + est);
    for (const std::string &id : ids) io::KittiLayout::check_id(id);

    lidarflow::cli::inputs_begin();
    const eval::KittiEvaluation ev = eval::evaluate_kitti(root, est, ids, opt, args.str("lidar", ""));
    std::printf("%s", eval::format_tables(ev).c_str());
    if (args.has("confidence")) {
        const std::string dir = args.str("confidence", "");
        std::vector<eval::Sparsification> curves;
        for (const std::string &id : ids) {
            try {
                curves.push_back(eval::sparsify(eval::load_ground_truth(root, id).occ, eval::load_estimate(est, id),
                                                eval::load_confidence(dir, id)));
            } catch (const Error &e) {
                throw Error(e.code(), "frame " + id + ": " + e.what());
            }
        }
        std::printf("\n%s", eval::format_sparsification(ids, curves).c_str());
    }
    if (args.has("json")) {
        eval::write_json(args.str("json", ""), ev);
        std::printf("wrote %s\n", args.str("json", "").c_str());
    }
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(eval, "eval", "score a KITTI-format result folder against ground truth", run_eval, 40);
