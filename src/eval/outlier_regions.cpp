// SPDX-License-Identifier: MIT
#include "eval/outlier_regions.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace lidarflow::eval {
namespace {

std::string pct(double num, double den) {
    if (!(den > 0)) return "-";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", 100.0 * num / den);
    return buf;
}

std::string cell(const std::string &s, size_t w) { return std::string(w > s.size() ? w - s.size() : 0, ' ') + s; }

}  // namespace

OutlierBreakdown &OutlierBreakdown::operator+=(const OutlierBreakdown &o) {
    for (const OutlierRegion &r : o.regions) {
        bool found = false;
        for (OutlierRegion &mine : regions)
            if (mine.family == r.family && mine.name == r.name) {
                mine.scores += r.scores;
                found = true;
                break;
            }
        if (!found) regions.push_back(r);
    }
    return *this;
}

OutlierBreakdown outlier_breakdown(const FrameGroundTruth &gt, const Estimate &est, const DisparityMap *lidar_seeds,
                                   const cv::Mat1b *objects) {
    require(!gt.occ.d0.empty(), ErrorCode::InvalidArgument, "ground truth d0 (occ) is empty");
    const cv::Size size = gt.occ.d0.size();
    const int W = size.width, H = size.height;
    if (objects)
        require(objects->size() == size, ErrorCode::SizeMismatch,
                "object map must be " + std::to_string(W) + "x" + std::to_string(H));
    if (gt.has_noc)
        require(gt.noc.flow.valid.size() == size && gt.noc.d0.size() == size && gt.noc.d1.size() == size, ErrorCode::SizeMismatch, "noc ground truth differs in size from occ");
    if (lidar_seeds)
        require(lidar_seeds->size() == size, ErrorCode::SizeMismatch, "LiDAR seed map differs in size from the ground truth");

    std::vector<std::pair<std::string, std::string>> names;
    std::vector<cv::Mat1b> masks;
    // Returns the new region's index (not a reference: later regions reallocate the vector).
    auto add = [&](const char *family, const char *name, const cv::Mat1b &mask) {
        names.emplace_back(family, name);
        masks.push_back(mask);
        return masks.size() - 1;
    };
    add("all", "all", cv::Mat1b(size, uchar(1)));

    // At t1. NaN flow is rejected by evaluate_masks at valid pixels; invalid ones are not SF
    // pixels, whatever region they fall in.
    const size_t leaves = add("at t1", "leaves the image", cv::Mat1b::zeros(size));
    const size_t occluded = gt.has_noc ? add("at t1", "occluded", cv::Mat1b::zeros(size)) : 0;
    const size_t visible = add("at t1", gt.has_noc ? "visible" : "in the image", cv::Mat1b::zeros(size));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const float tx = x + gt.occ.flow.u(y, x), ty = y + gt.occ.flow.v(y, x);
            if (!(tx >= 0 && ty >= 0 && tx <= W - 1 && ty <= H - 1))
                masks[leaves](y, x) = 1;
            else if (gt.has_noc && !(gt.noc.flow.valid(y, x) && disparity_valid(gt.noc.d0(y, x)) &&
                                     disparity_valid(gt.noc.d1(y, x))))
                masks[occluded](y, x) = 1;
            else
                masks[visible](y, x) = 1;
        }

    if (lidar_seeds && cv::countNonZero(*lidar_seeds >= 0.0f) > 0) {
        cv::Mat1f dist;
        cv::distanceTransform(cv::Mat1b(*lidar_seeds < 0.0f), dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
        // The 15 px support windows reach 7 px in L-infinity; 7.5 px in L2 is the round figure.
        add("LiDAR", "<= 7 px from a seed", dist <= 7.5f);
        add("LiDAR", "8-30 px", (dist > 7.5f) & (dist <= 30.0f));
        add("LiDAR", "> 30 px", dist > 30.0f);
    }

    const DisparityMap &d = gt.occ.d0;
    add("depth", "near: d0 >= 40 px", d >= 40.0f);
    add("depth", "mid: d0 10-40 px", (d >= 10.0f) & (d < 40.0f));
    add("depth", "far: d0 < 10 px", (d >= 0.0f) & (d < 10.0f));

    if (objects) {
        add("objects", "background", *objects == 0);
        add("objects", "objects", *objects != 0);
    }

    const std::vector<ComponentScores> scores = evaluate_masks(gt.occ, est, FillMode::Filled, masks);
    OutlierBreakdown b;
    for (size_t i = 0; i < masks.size(); ++i) b.regions.push_back({names[i].first, names[i].second, scores[i]});
    return b;
}

std::string format_outlier_breakdown(const OutlierBreakdown &b, const OutlierBreakdown *compare,
                                     const std::string &compare_name) {
    std::ostringstream s;
    if (b.regions.empty()) return "";
    const ComponentScores &all = b.regions.front().scores;
    const double px = double(all.sf.n_gt), outl = double(all.sf.n_err);
    s << "Where the SF outliers are (occ ground truth, holes filled; pooled over frames)\n";
    s << std::string(30, ' ') << cell("pixels", 9) << cell("SF", 9) << cell("share of", 10) << cell("D0", 8)
      << cell("D1", 8) << cell("Fl", 8);
    if (compare) s << cell(compare_name, 14);
    s << "\n" << std::string(30, ' ') << cell("[%]", 9) << cell("[%]", 9) << cell("outl. [%]", 10) << cell("[%]", 8)
      << cell("[%]", 8) << cell("[%]", 8);
    if (compare) s << cell("SF [%]", 14);
    s << "\n";
    std::string family;
    for (const OutlierRegion &r : b.regions) {
        const ComponentScores &c = r.scores;
        std::string label = r.family == "all" ? r.name : (r.family == family ? "  " : r.family + ": ") + r.name;
        if (label.size() > 29) label.resize(29);
        family = r.family;
        s << label << std::string(30 - label.size(), ' ') << cell(pct(double(c.sf.n_gt), px), 9)
          << cell(pct(double(c.sf.n_err), double(c.sf.n_total)), 9) << cell(pct(double(c.sf.n_err), outl), 10)
          << cell(pct(double(c.d0.n_err), double(c.d0.n_total)), 8)
          << cell(pct(double(c.d1.n_err), double(c.d1.n_total)), 8)
          << cell(pct(double(c.fl.n_err), double(c.fl.n_total)), 8);
        if (compare) {
            std::string v = "-";
            for (const OutlierRegion &o : compare->regions)
                if (o.family == r.family && o.name == r.name)
                    v = pct(double(o.scores.sf.n_err), double(o.scores.sf.n_total));
            s << cell(v, 14);
        }
        s << "\n";
    }
    return s.str();
}

}  // namespace lidarflow::eval
