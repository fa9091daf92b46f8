// SPDX-License-Identifier: MIT
#include "viz/birds_eye.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "viz/legend.hpp"

namespace lidarflow::viz {
namespace {

const cv::Scalar kMarks(255, 255, 255), kDistanceLine(70, 70, 70), kDistanceLabel(150, 150, 150);

double percentile(std::vector<double> v, double q) {
    const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

// Object motion where the cloud has it: the static world then stays still and movers stand out.
const cv::Vec3f &shown_motion(const io::CloudPoint &p) { return p.has_object_motion ? p.object_motion : p.motion; }
double speed(const io::CloudPoint &p) { return cv::norm(shown_motion(p)); }

}  // namespace

cv::Vec3b speed_color(double s, double max_speed) {
    static const cv::Mat lut = [] {
        cv::Mat ramp(1, 256, CV_8U);
        for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(i);
        cv::Mat colours;
        cv::applyColorMap(ramp, colours, cv::COLORMAP_TURBO);
        return colours;
    }();
    const double t = max_speed > 0 ? std::min(std::max(s / max_speed, 0.0), 1.0) : 0.0;
    return lut.at<cv::Vec3b>(0, static_cast<int>(std::lround(t * 255.0)));
}

cv::Mat birds_eye_view(const std::vector<io::CloudPoint> &points, const BirdsEyeOptions &o) {
    require(!points.empty(), ErrorCode::InvalidArgument, "birds_eye_view: no points");
    require(std::isfinite(o.range) && o.range >= 0 && o.height >= 64 && o.height <= 8192 &&
                std::isfinite(o.max_speed) && o.max_speed >= 0 && std::isfinite(o.cell) && o.cell > 0 &&
                o.min_points >= 1,
            ErrorCode::InvalidArgument, "birds_eye_view: options out of range");
    std::vector<double> depths, speeds;
    depths.reserve(points.size());
    speeds.reserve(points.size());
    for (const io::CloudPoint &p : points) {
        require(cv::checkRange(p.position) && cv::checkRange(p.motion) &&
                    (!p.has_object_motion || cv::checkRange(p.object_motion)),
                ErrorCode::InvalidArgument, "birds_eye_view: non-finite point");
        require(p.has_object_motion == points[0].has_object_motion, ErrorCode::InvalidArgument,
                "birds_eye_view: either every point has its object motion or none");
        depths.push_back(p.position[2]);
        speeds.push_back(speed(p));
    }
    const double range = o.range > 0 ? o.range : std::min(std::max(percentile(depths, 0.98), 10.0), 80.0);
    double max_speed = o.max_speed > 0 ? o.max_speed : percentile(speeds, 0.98);
    if (!(max_speed > 0)) max_speed = 1;  // nothing moves: any scale draws it all in the lowest colour
    const double ppm = o.height / range;
    const int size = o.height;
    auto to_pixel = [&](double x, double z) {
        return cv::Point2d((x + range / 2) * ppm, (range - z) * ppm);
    };

    cv::Mat view(size, size, CV_8UC3, cv::Scalar(20, 20, 20));
    // Distance lines every 10 m (5 m when the range is short).
    const double step = range > 30 ? 10 : 5;
    for (double z = step; z < range; z += step) {
        const int y = static_cast<int>(std::lround(to_pixel(0, z).y));
        cv::line(view, {0, y}, {size - 1, y}, kDistanceLine);
        // Above its line, unless that would cut the label at the top edge: then below it.
        const std::string label = std::to_string(static_cast<int>(z)) + " m";
        int base = 0;
        const int text_h = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &base).height;
        const int baseline = y - 4 - text_h >= 1 ? y - 4 : y + 4 + text_h;
        cv::putText(view, label, {4, baseline}, cv::FONT_HERSHEY_SIMPLEX, 0.4, kDistanceLabel, 1, cv::LINE_AA);
    }
    // Slow points first so that movers stay on top.
    std::vector<size_t> order(points.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return speeds[a] < speeds[b]; });
    std::map<std::pair<long, long>, std::pair<int, cv::Vec4d>> cells;  // count, sum of (x, z, dx, dz)
    for (size_t i : order) {
        const io::CloudPoint &p = points[i];
        const cv::Point2d q = to_pixel(p.position[0], p.position[2]);
        if (!(q.x >= 0 && q.y >= 0 && q.x < size && q.y < size)) continue;
        view.at<cv::Vec3b>(static_cast<int>(q.y), static_cast<int>(q.x)) = speed_color(speeds[i], max_speed);
        auto &c = cells[{static_cast<long>(std::floor(p.position[0] / o.cell)),
                         static_cast<long>(std::floor(p.position[2] / o.cell))}];
        ++c.first;
        const cv::Vec3f &m = shown_motion(p);
        c.second += cv::Vec4d(p.position[0], p.position[2], m[0], m[2]);
    }
    for (const auto &kv : cells) {
        if (kv.second.first < o.min_points) continue;
        const cv::Vec4d m = kv.second.second / kv.second.first;
        if (std::hypot(m[2], m[3]) * ppm < 2) continue;  // shorter than 2 px: a dot says nothing
        const cv::Point2d a = to_pixel(m[0], m[1]), b = to_pixel(m[0] + m[2], m[1] + m[3]);
        cv::arrowedLine(view, a, b, kMarks, 1, cv::LINE_AA, 0, 0.3);
    }
    // The camera, looking up the picture.
    const cv::Point2d cam = to_pixel(0, 0);
    const cv::Point tri[3] = {cv::Point(static_cast<int>(cam.x), size - 12), cv::Point(static_cast<int>(cam.x) - 7, size - 1),
                              cv::Point(static_cast<int>(cam.x) + 7, size - 1)};
    cv::fillConvexPoly(view, tri, 3, kMarks, cv::LINE_AA);
    const bool object = points[0].has_object_motion;
    const cv::Mat with_bar = with_color_bar(
        view, [max_speed](double s) { return speed_color(s, max_speed); }, 0.0, max_speed,
        object ? "|object motion| [m / frame]" : "|motion| [m / frame]");
    char cell[96];
    std::snprintf(cell, sizeof cell, "mean %s of the points of a %g x %g m cell, to the map's scale",
                  object ? "object motion" : "motion", o.cell, o.cell);
    return with_marks_legend(with_bar, {{LegendMark::Glyph::Triangle, kMarks, "camera, looking up the picture"},
                                        {LegendMark::Glyph::Arrow, kMarks, cell},
                                        {LegendMark::Glyph::Line, kDistanceLabel, "distance ahead of the camera"}});
}

}  // namespace lidarflow::viz
