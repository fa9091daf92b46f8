// SPDX-License-Identifier: MIT
// lidarflow viz: colour-codes a disparity or flow map in any format `run --format` writes (with
// its legend, optionally over the camera image), draws its KITTI error map against ground truth,
// or draws a bird's-eye view of the point cloud `run --points` writes.
#include <cmath>
#include <cstdio>
#include <string>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "core/size_text.hpp"
#include "io/image_file.hpp"
#include "io/kitti_png.hpp"
#include "io/point_cloud.hpp"
#include "io/result_formats.hpp"
#include "viz/birds_eye.hpp"
#include "viz/disparity_color.hpp"
#include "viz/error_map.hpp"
#include "viz/flow_color.hpp"
#include "viz/legend.hpp"
#include "viz/overlay.hpp"

namespace lidarflow::cli {
namespace {

// Inputs drawn together must be of one size; the message names both.
void same_size(cv::Size a, const char *what_a, cv::Size b, const char *what_b) {
    require(a == b, ErrorCode::SizeMismatch, [&] {
        return std::string("viz: ") + what_a + " is " + size_text(a) + " but " + what_b + " is " + size_text(b);
    });
}

int birds_eye(const Args &args, const std::string &out) {
    require(!args.has("gt") && !args.has("gt-noc") && !args.has("style") && !args.has("image") &&
                !args.has("no-legend"),
            ErrorCode::InvalidArgument, "viz: --points takes only --range, --max and --out");
    viz::BirdsEyeOptions o;
    o.range = args.number("range", 0);
    require(o.range >= 0, ErrorCode::InvalidArgument, "viz: --range must be >= 0 (0 = automatic)");
    o.max_speed = args.number("max", 0);
    require(o.max_speed >= 0, ErrorCode::InvalidArgument, "viz: --max must be >= 0 (0 = automatic)");
    const std::string path = args.str("points", "");
    inputs_begin();
    const std::vector<io::CloudPoint> cloud = io::read_ply(path);
    require(!cloud.empty(), ErrorCode::InvalidArgument, "viz: " + path + " holds no points");
    const cv::Mat picture = viz::birds_eye_view(cloud, o);
    io::write_image(out, picture);
    std::printf("wrote %s: bird's-eye view of %zu points (colour = %s), %dx%d\n", out.c_str(), cloud.size(),
                cloud[0].has_object_motion ? "|object motion|, ego-motion removed" : "|motion| relative to the camera",
                picture.cols, picture.rows);
    return 0;
}

int run_viz(int argc, char **argv) {
    Args args("viz", argc, argv,
              {{"disp", true, "FILE  disparity map: KITTI PNG (uint16, d*256), .pfm or .npy (float, NaN = none)"},
               {"flow", true, "FILE  flow: KITTI PNG (3 x uint16), .flo, .pfm or .npy (u, v[, valid])"},
               {"points", true, "PLY  point cloud of `run --points`: draw a bird's-eye view of the (object) motion"},
               {"gt", true, "FILE  ground truth (occ) of the same kind, any of those formats: draw the error map instead"},
               {"gt-noc", true, "FILE  non-occluded ground truth: occluded-only pixels drawn darker"},
               {"image", true, "IMG  camera image (left, t0; PNG, JPEG, BMP, PGM/PPM): draw the colours over it"},
               {"out", true, "PNG  output picture (BGR, 8-bit)"},
               {"max", true, "V  colour scale: max disparity / flow [px] / speed [m per frame] (default: the data's)"},
               {"range", true, "M  --points: metres shown ahead (default: the data's)"},
               {"style", true, "kitti|middlebury  flow colour wheel (default kitti)"},
               {"no-legend", false, "no colour bar / wheel / error scale strip: the picture keeps the map's size"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    const bool disp = args.has("disp"), flow = args.has("flow"), error_map = args.has("gt");
    require(disp + flow + args.has("points") == 1, ErrorCode::InvalidArgument,
            "viz: give exactly one of --disp, --flow and --points");
    const std::string out = args.required("out");
    if (args.has("points")) return birds_eye(args, out);
    require(!args.has("range"), ErrorCode::InvalidArgument, "viz: --range applies to --points");
    require(!(error_map && args.has("max")), ErrorCode::InvalidArgument,
            "viz: --max sets the colour scale of a plain picture; an error map has a fixed scale");
    require(!args.has("gt-noc") || error_map, ErrorCode::InvalidArgument, "viz: --gt-noc needs --gt");
    require(!args.has("style") || flow, ErrorCode::InvalidArgument, "viz: --style applies to --flow");
    const double max = args.number("max", 0);
    require(max >= 0, ErrorCode::InvalidArgument, "viz: --max must be >= 0 (0 = automatic)");
    const bool legend = !args.flag("no-legend");
    const std::string style = args.str("style", "kitti");
    require(style == "kitti" || style == "middlebury", ErrorCode::InvalidArgument,
            "viz: --style must be kitti or middlebury, got '" + style + "'");
    inputs_begin();

    cv::Mat picture;
    cv::Mat1b valid;  // where the picture shows the result (for --image)
    std::string what;
    const auto over_image = [&](cv::Mat &pic, const cv::Mat1b &shown, std::string &text) {
        const cv::Mat image = io::read_any_image(args.str("image", ""));
        same_size(image.size(), "--image", pic.size(), disp ? "the --disp map" : "the --flow map");
        pic = viz::blend_over(image, pic, shown, 0.6);
        text += " over the image";
    };
    if (disp) {
        const DisparityMap est = io::read_disparity_file(args.str("disp", ""));
        valid = est >= 0.0f;
        if (error_map) {
            const DisparityMap noc = args.has("gt-noc") ? io::read_disparity_file(args.str("gt-noc", "")) : DisparityMap();
            const DisparityMap gt = io::read_disparity_file(args.str("gt", ""));
            same_size(gt.size(), "--gt", est.size(), "--disp");
            if (!noc.empty()) same_size(noc.size(), "--gt-noc", est.size(), "--disp");
            picture = viz::disparity_error_image(est, gt, noc);
            what = "disparity error map (log colours, 1 = KITTI outlier threshold)";
        } else {
            const double scale = viz::disparity_color_scale(est, static_cast<float>(max));
            picture = viz::disparity_to_color(est, static_cast<float>(scale));
            what = "disparity colour map, scale 0.." + std::to_string(static_cast<int>(std::ceil(scale))) + " px";
        }
        if (args.has("image")) over_image(picture, valid, what);
        if (legend)
            picture = error_map ? viz::with_error_legend(picture)
                                : viz::with_disparity_legend(picture, viz::disparity_color_scale(est, static_cast<float>(max)));
    } else {
        const FlowField est = io::read_flow_file(args.str("flow", ""));
        valid = est.valid != 0;
        viz::FlowColorOptions o;
        if (error_map) {
            const FlowField noc = args.has("gt-noc") ? io::read_flow_file(args.str("gt-noc", "")) : FlowField();
            const FlowField gt = io::read_flow_file(args.str("gt", ""));
            same_size(gt.u.size(), "--gt", est.u.size(), "--flow");
            if (!noc.u.empty()) same_size(noc.u.size(), "--gt-noc", est.u.size(), "--flow");
            picture = viz::flow_error_image(est, gt, noc);
            what = "flow error map (log colours, 1 = KITTI outlier threshold)";
        } else {
            o.style = style == "kitti" ? viz::FlowColorStyle::Kitti : viz::FlowColorStyle::Middlebury;
            o.max_flow = static_cast<float>(max);
            picture = viz::flow_to_color(est, o);
            what = "flow colour (" + style + " wheel)";
        }
        if (args.has("image")) over_image(picture, valid, what);
        if (legend)
            picture = error_map ? viz::with_error_legend(picture)
                                : viz::with_flow_legend(picture, viz::flow_color_scale(est, o), o.style);
    }
    io::write_image(out, picture);
    std::printf("wrote %s: %s%s, %dx%d\n", out.c_str(), what.c_str(), legend ? " with legend" : "", picture.cols,
                picture.rows);
    return 0;
}

}  // namespace
}  // namespace lidarflow::cli

LIDARFLOW_COMMAND(viz, "viz", "colour-code a disparity/flow PNG (legend, over the image), its error map, or a bird's-eye view",
                  lidarflow::cli::run_viz, 50);
