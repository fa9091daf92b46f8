// SPDX-License-Identifier: MIT
#include "eval/json_report.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.hpp"

namespace lidarflow::eval {
namespace {

// ordered_json: keys stay in the order written below (the documented layout), not sorted.
using Json = nlohmann::ordered_json;

// JSON has no NaN: an undefined value (nothing to score) is null. nlohmann would also dump a
// NaN as null, but saying it here keeps the schema independent of that library default.
Json number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json counts(const Counts &c, bool with_epe) {
    Json j;
    j["outlier_pct"] = number(c.outlier_pct());
    if (with_epe) j["epe"] = number(c.epe());
    j["density_pct"] = number(c.density_pct());
    j["n_err"] = static_cast<int64_t>(c.n_err);
    j["n_total"] = static_cast<int64_t>(c.n_total);
    j["n_est"] = static_cast<int64_t>(c.n_est);
    j["n_gt"] = static_cast<int64_t>(c.n_gt);
    return j;
}

Json components(const ComponentScores &s) {
    Json j;
    j["d0"] = counts(s.d0, true);
    j["d1"] = counts(s.d1, true);
    j["fl"] = counts(s.fl, true);
    j["sf"] = counts(s.sf, false);
    return j;
}

Json region(const RegionScores &r) {
    Json j;
    j["occ"] = components(r.occ);
    if (r.has_noc) j["noc"] = components(r.noc);
    return j;
}

Json frame(const FrameScore &f) {
    Json j;
    j["id"] = f.id;
    j["dense"] = region(f.dense);
    if (f.has_lidar) {
        Json l;
        l["n_seeds"] = static_cast<int64_t>(f.n_seeds);
        l["seeds"] = region(f.seeds);
        l["window"] = region(f.window);
        l["window_excl_seeds"] = region(f.window_excl_seeds);
        j["lidar"] = std::move(l);
    }
    return j;
}

Json mean(const MeanStat &m, bool with_epe) {
    Json j;
    j["outlier_pct"] = number(m.outlier_pct);
    if (with_epe) j["epe"] = number(m.epe);
    j["density_pct"] = number(m.density_pct);
    j["frames_scored"] = static_cast<int64_t>(m.frames_scored);
    j["frames_with_gt"] = static_cast<int64_t>(m.frames_with_gt);
    return j;
}

Json mean_components(const ComponentMeans &m) {
    Json j;
    j["d0"] = mean(m.d0, true);
    j["d1"] = mean(m.d1, true);
    j["fl"] = mean(m.fl, true);
    j["sf"] = mean(m.sf, false);
    return j;
}

Json mean_region(const RegionMeans &m) {
    Json j;
    j["occ"] = mean_components(m.occ);
    if (m.has_noc) j["noc"] = mean_components(m.noc);
    return j;
}

}  // namespace

const char *mode_name(FillMode mode) { return mode == FillMode::Filled ? "filled" : "est-only"; }

std::string to_json(const KittiEvaluation &ev) {
    Json j;
    j["format"] = "lidarflow-eval/1";
    j["mode"] = mode_name(ev.options.mode);
    j["window"] = static_cast<int64_t>(ev.options.window);
    j["frames"] = Json::array();
    for (const FrameScore &f : ev.frames) j["frames"].push_back(frame(f));
    j["pooled"] = frame(ev.summary.pooled);
    Json means;
    means["dense"] = mean_region(ev.summary.mean_dense);
    if (ev.summary.pooled.has_lidar) {
        means["seeds"] = mean_region(ev.summary.mean_seeds);
        means["window"] = mean_region(ev.summary.mean_window);
        means["window_excl_seeds"] = mean_region(ev.summary.mean_window_excl_seeds);
    }
    j["mean_over_frames"] = std::move(means);
    // dump() writes the shortest text that round-trips each double; frame ids come from file
    // names, so a byte that is not UTF-8 is replaced (U+FFFD) rather than thrown on.
    return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

void write_json(const std::string &path, const KittiEvaluation &ev) {
    const std::string text = to_json(ev);
    const auto parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    require(!ec, ErrorCode::Io, "cannot create folder " + parent.string() + ": " + ec.message());
    std::ofstream f(path, std::ios::binary);
    require(f.good(), ErrorCode::Io, "cannot write " + path);
    f << text;
    f.close();
    require(!f.fail(), ErrorCode::Io, "cannot write " + path);
}

std::string to_json(const OutlierBreakdown &b) {
    Json a = Json::array();
    for (const OutlierRegion &r : b.regions) {
        Json j;
        j["family"] = r.family;
        j["region"] = r.name;
        j["occ"] = components(r.scores);
        a.push_back(std::move(j));
    }
    return a.dump();
}

}  // namespace lidarflow::eval
