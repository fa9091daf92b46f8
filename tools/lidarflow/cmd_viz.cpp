// lidarflow viz: colour-codes a KITTI disparity or flow PNG, or draws its KITTI error map
// against ground truth.
#include <cstdio>
#include <string>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "io/kitti_png.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"
#include "viz/flow_color.hpp"

namespace lidarflow::cli {
namespace {

int run_viz(int argc, char **argv) {
    Args args("viz", argc, argv,
              {{"disp", true, "FILE  KITTI disparity PNG (uint16, d*256)"},
               {"flow", true, "FILE  KITTI flow PNG (3 x uint16)"},
               {"gt", true, "FILE  ground truth (occ) of the same kind: draw the error map instead"},
               {"gt-noc", true, "FILE  non-occluded ground truth: occluded-only pixels drawn darker"},
               {"out", true, "PNG  output picture (BGR, 8-bit)"},
               {"max", true, "V  colour scale: max disparity / max flow in px (default: the data's)"},
               {"style", true, "kitti|middlebury  flow colour wheel (default kitti)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    const bool disp = args.has("disp"), flow = args.has("flow"), error_map = args.has("gt");
    require(disp != flow, ErrorCode::InvalidArgument, "viz: give exactly one of --disp and --flow");
    const std::string out = args.required("out");
    require(!(error_map && args.has("max")), ErrorCode::InvalidArgument,
            "viz: --max sets the colour scale of a plain picture; an error map has a fixed scale");
    require(!args.has("gt-noc") || error_map, ErrorCode::InvalidArgument, "viz: --gt-noc needs --gt");
    require(!args.has("style") || flow, ErrorCode::InvalidArgument, "viz: --style applies to --flow");
    const double max = args.number("max", 0);
    require(max >= 0, ErrorCode::InvalidArgument, "viz: --max must be >= 0 (0 = automatic)");

    cv::Mat picture;
    std::string what;
    if (disp) {
        const DisparityMap est = io::read_disparity_png(args.str("disp", ""));
        if (error_map) {
            const DisparityMap noc = args.has("gt-noc") ? io::read_disparity_png(args.str("gt-noc", "")) : DisparityMap();
            picture = viz::disparity_error_image(est, io::read_disparity_png(args.str("gt", "")), noc);
            what = "disparity error map (log colours, 1.0 = KITTI outlier threshold)";
        } else {
            picture = viz::disparity_to_color(est, static_cast<float>(max));
            what = "disparity colour map";
        }
    } else {
        const FlowField est = io::read_flow_png(args.str("flow", ""));
        if (error_map) {
            const FlowField noc = args.has("gt-noc") ? io::read_flow_png(args.str("gt-noc", "")) : FlowField();
            picture = viz::flow_error_image(est, io::read_flow_png(args.str("gt", "")), noc);
            what = "flow error map (log colours, 1.0 = KITTI outlier threshold)";
        } else {
            viz::FlowColorOptions o;
            const std::string style = args.str("style", "kitti");
            require(style == "kitti" || style == "middlebury", ErrorCode::InvalidArgument,
                    "viz: --style must be kitti or middlebury, got '" + style + "'");
            o.style = style == "kitti" ? viz::FlowColorStyle::Kitti : viz::FlowColorStyle::Middlebury;
            o.max_flow = static_cast<float>(max);
            picture = viz::flow_to_color(est, o);
            what = "flow colour (" + style + " wheel)";
        }
    }
    io::write_image(out, picture);
    std::printf("wrote %s: %s, %dx%d\n", out.c_str(), what.c_str(), picture.cols, picture.rows);
    return 0;
}

}  // namespace
}  // namespace lidarflow::cli

LIDARFLOW_COMMAND(viz, "viz", "colour-code a KITTI disparity/flow PNG, or its error map against ground truth",
                  lidarflow::cli::run_viz, 50);
