// SPDX-License-Identifier: MIT
#include "eval/metrics.hpp"

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/maps.hpp"
#include "eval/background_fill.hpp"

namespace lidarflow::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The devkit's thresholds, compared in the devkit's arithmetic (float errors, double constants).
constexpr double kAbsThresh = 3.0;
constexpr double kRelThresh = 0.05;

std::string at(int x, int y) { return "(x=" + std::to_string(x) + ", y=" + std::to_string(y) + ")"; }

double ratio_pct(double num, int64_t den) { return den > 0 ? 100.0 * num / static_cast<double>(den) : kNaN; }

void check_disparity(const DisparityMap &d, const cv::Size &size, const std::string &what) {
    require(!d.empty(), ErrorCode::InvalidArgument, what + " is empty");
    require(d.size() == size, ErrorCode::SizeMismatch,
            what + " is " + std::to_string(d.cols) + "x" + std::to_string(d.rows) + ", expected " +
                std::to_string(size.width) + "x" + std::to_string(size.height));
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x)
            if (!std::isfinite(d(y, x))) throw Error(ErrorCode::InvalidArgument, what + " holds NaN/inf at " + at(x, y));
}

// Values at invalid flow pixels are never read (the devkit reads them as 0), so only valid
// pixels must be finite.
void check_flow(const FlowField &f, const cv::Size &size, const std::string &what) {
    require(!f.u.empty(), ErrorCode::InvalidArgument, what + " is empty");
    require(f.u.size() == size && f.v.size() == size && f.valid.size() == size, ErrorCode::SizeMismatch,
            what + ": u, v, valid must all be " + std::to_string(size.width) + "x" +
                std::to_string(size.height));
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
            if (f.valid(y, x) && !(std::isfinite(f.u(y, x)) && std::isfinite(f.v(y, x))))
                throw Error(ErrorCode::InvalidArgument, what + " holds NaN/inf at valid pixel " + at(x, y));
}

void check_ground_truth(const GroundTruth &gt, const cv::Size &size, const std::string &tag) {
    check_disparity(gt.d0, size, "ground truth d0 (" + tag + ")");
    check_disparity(gt.d1, size, "ground truth d1 (" + tag + ")");
    check_flow(gt.flow, size, "ground truth flow (" + tag + ")");
}

void check_estimate(const Estimate &est, const cv::Size &size) {
    check_disparity(est.d0, size, "estimate d0");
    check_disparity(est.d1, size, "estimate d1");
    check_flow(est.flow, size, "estimate flow");
}

// The estimate as the devkit holds it: unfilled maps (for validity / density) and the maps the
// errors are taken from (filled in Filled mode; in EstimateOnly mode only valid pixels are
// scored, so the unfilled maps serve).
struct Prepared {
    DisparityMap d0, d1;
    FlowField flow;
    DisparityMap d0_scored, d1_scored;
    FlowField flow_scored;
};

DisparityMap normalised(const DisparityMap &d) {
    DisparityMap out = d.clone();
    out.setTo(kInvalidDisparity, out < 0.0f);
    return out;
}

FlowField normalised(const FlowField &f) {
    FlowField out{f.u.clone(), f.v.clone(), f.valid.clone()};
    const cv::Mat1b holes = out.valid == 0;
    out.u.setTo(0.0f, holes);
    out.v.setTo(0.0f, holes);
    out.valid.setTo(1, ~holes);
    return out;
}

Prepared prepare(const Estimate &est, FillMode mode) {
    Prepared p{normalised(est.d0), normalised(est.d1), normalised(est.flow), {}, {}, {}};
    if (mode == FillMode::Filled) {
        p.d0_scored = fill_background(p.d0);
        p.d1_scored = fill_background(p.d1);
        p.flow_scored = fill_background(p.flow);
    } else {
        p.d0_scored = p.d0;
        p.d1_scored = p.d1;
        p.flow_scored = p.flow;
    }
    return p;
}

void add_pixel(Counts &c, bool est_valid, bool scored, bool outlier, double abs_err) {
    ++c.n_gt;
    if (est_valid) ++c.n_est;
    if (!scored) return;
    ++c.n_total;
    if (outlier) ++c.n_err;
    c.abs_err_sum += abs_err;
}

// One pass over the pixels of `mask` (all pixels when null).
ComponentScores score(const GroundTruth &gt, const Prepared &e, FillMode mode, const cv::Mat1b *mask) {
    ComponentScores s;
    const bool filled = mode == FillMode::Filled;
    for (int y = 0; y < gt.d0.rows; ++y) {
        for (int x = 0; x < gt.d0.cols; ++x) {
            if (mask && !(*mask)(y, x)) continue;
            const float g0 = gt.d0(y, x), g1 = gt.d1(y, x);
            const bool g0_ok = disparity_valid(g0), g1_ok = disparity_valid(g1);
            const bool gf_ok = gt.flow.valid(y, x) != 0;
            const bool e0_ok = disparity_valid(e.d0(y, x)), e1_ok = disparity_valid(e.d1(y, x));
            const bool ef_ok = e.flow.valid(y, x) != 0;

            const float s0 = e.d0_scored(y, x), s1 = e.d1_scored(y, x);
            const float gu = gt.flow.u(y, x), gv = gt.flow.v(y, x);
            const float su = e.flow_scored.u(y, x), sv = e.flow_scored.v(y, x);
            const bool out0 = g0_ok && disparity_outlier(g0, s0);
            const bool out1 = g1_ok && disparity_outlier(g1, s1);
            const bool outf = gf_ok && flow_outlier(gu, gv, su, sv);

            if (g0_ok) add_pixel(s.d0, e0_ok, filled || e0_ok, out0, std::fabs(g0 - s0));
            if (g1_ok) add_pixel(s.d1, e1_ok, filled || e1_ok, out1, std::fabs(g1 - s1));
            if (gf_ok) {
                const float du = gu - su, dv = gv - sv;
                add_pixel(s.fl, ef_ok, filled || ef_ok, outf, std::sqrt(du * du + dv * dv));
            }
            // Devkit: the SF density looks at the d0 estimate only; scoring in EstimateOnly
            // mode needs the whole 4-vector.
            if (g0_ok && g1_ok && gf_ok)
                add_pixel(s.sf, e0_ok, filled || (e0_ok && e1_ok && ef_ok), out0 || out1 || outf, 0.0);
        }
    }
    return s;
}

RegionScores score_region(const FrameGroundTruth &gt, const Prepared &e, FillMode mode, const cv::Mat1b *mask) {
    RegionScores r;
    r.occ = score(gt.occ, e, mode, mask);
    r.has_noc = gt.has_noc;
    if (gt.has_noc) r.noc = score(gt.noc, e, mode, mask);
    return r;
}

void add_region(RegionScores &acc, const RegionScores &r) {
    acc.occ += r.occ;
    acc.noc += r.noc;
}

void add_mean(MeanStat &m, const Counts &c) {
    if (c.n_total > 0) {
        m.outlier_pct += c.outlier_pct();
        m.epe += c.epe();
        ++m.frames_scored;
    }
    if (c.n_gt > 0) {
        m.density_pct += c.density_pct();
        ++m.frames_with_gt;
    }
}

void finish_mean(MeanStat &m) {
    m.outlier_pct = m.frames_scored ? m.outlier_pct / m.frames_scored : kNaN;
    m.epe = m.frames_scored ? m.epe / m.frames_scored : kNaN;
    m.density_pct = m.frames_with_gt ? m.density_pct / m.frames_with_gt : kNaN;
}

RegionMeans mean_of(const std::vector<FrameScore> &frames, RegionScores FrameScore::*region, bool has_noc) {
    RegionMeans m;
    m.has_noc = has_noc;
    for (const FrameScore &f : frames) {
        const RegionScores &r = f.*region;
        add_mean(m.occ.d0, r.occ.d0);
        add_mean(m.occ.d1, r.occ.d1);
        add_mean(m.occ.fl, r.occ.fl);
        add_mean(m.occ.sf, r.occ.sf);
        if (has_noc) {
            add_mean(m.noc.d0, r.noc.d0);
            add_mean(m.noc.d1, r.noc.d1);
            add_mean(m.noc.fl, r.noc.fl);
            add_mean(m.noc.sf, r.noc.sf);
        }
    }
    for (ComponentMeans *c : {&m.occ, &m.noc})
        for (MeanStat *s : {&c->d0, &c->d1, &c->fl, &c->sf}) finish_mean(*s);
    return m;
}

}  // namespace

// The relative test divides in float, as the devkit does: 5.0f / 100.0f rounds above 0.05, so
// an error of exactly 5 % counts as an outlier there, and must here.
bool disparity_outlier(float gt, float est) {
    const float err = std::fabs(gt - est);
    // A zero ground truth makes the relative error infinite in the devkit: any err > 3 counts.
    return err > kAbsThresh && (gt == 0.0f || err / std::fabs(gt) > kRelThresh);
}

bool flow_outlier(float gt_u, float gt_v, float est_u, float est_v) {
    const float du = gt_u - est_u, dv = gt_v - est_v;
    const float dist = std::sqrt(du * du + dv * dv);
    const float mag = std::sqrt(gt_u * gt_u + gt_v * gt_v);
    return dist > kAbsThresh && (mag == 0.0f || dist / mag > kRelThresh);
}

double Counts::outlier_pct() const { return ratio_pct(static_cast<double>(n_err), n_total); }
double Counts::epe() const { return n_total > 0 ? abs_err_sum / static_cast<double>(n_total) : kNaN; }
double Counts::density_pct() const { return ratio_pct(static_cast<double>(n_est), n_gt); }

Counts &Counts::operator+=(const Counts &o) {
    n_gt += o.n_gt;
    n_est += o.n_est;
    n_total += o.n_total;
    n_err += o.n_err;
    abs_err_sum += o.abs_err_sum;
    return *this;
}

ComponentScores &ComponentScores::operator+=(const ComponentScores &o) {
    d0 += o.d0;
    d1 += o.d1;
    fl += o.fl;
    sf += o.sf;
    return *this;
}

Estimate estimate_from_scene_flow(const SceneFlowField &sf) {
    require(!sf.u.empty(), ErrorCode::InvalidArgument, "scene flow estimate is empty");
    const cv::Size size = sf.u.size();
    require(sf.v.size() == size && sf.d0.size() == size && sf.d1.size() == size && sf.valid.size() == size,
            ErrorCode::SizeMismatch, "scene flow estimate: u, v, d0, d1, valid differ in size");
    Estimate e{filled(size, kInvalidDisparity), filled(size, kInvalidDisparity),
               FlowField::zeros(size.width, size.height)};
    for (int y = 0; y < size.height; ++y) {
        for (int x = 0; x < size.width; ++x) {
            if (!sf.valid(y, x)) continue;
            const float u = sf.u(y, x), v = sf.v(y, x), d0 = sf.d0(y, x), d1 = sf.d1(y, x);
            if (!(std::isfinite(u) && std::isfinite(v) && std::isfinite(d0) && std::isfinite(d1)))
                throw Error(ErrorCode::InvalidArgument, "scene flow estimate holds NaN/inf at valid pixel " + at(x, y));
            e.d0(y, x) = disparity_valid(d0) ? d0 : kInvalidDisparity;
            e.d1(y, x) = disparity_valid(d1) ? d1 : kInvalidDisparity;
            e.flow.u(y, x) = u;
            e.flow.v(y, x) = v;
            e.flow.valid(y, x) = 1;
        }
    }
    return e;
}

FrameScore evaluate_frame(const FrameGroundTruth &gt, const Estimate &est, const EvalOptions &opt,
                          const DisparityMap *lidar_seeds, const std::string &id) {
    require(!gt.occ.d0.empty(), ErrorCode::InvalidArgument, "ground truth d0 (occ) is empty");
    const cv::Size size = gt.occ.d0.size();
    check_ground_truth(gt.occ, size, "occ");
    if (gt.has_noc) check_ground_truth(gt.noc, size, "noc");
    check_estimate(est, size);
    if (lidar_seeds) {
        check_disparity(*lidar_seeds, size, "LiDAR seed map");
        require(opt.window >= 1 && opt.window % 2 == 1, ErrorCode::InvalidArgument,
                "support window must be odd and >= 1, got " + std::to_string(opt.window));
    }

    const Prepared e = prepare(est, opt.mode);
    FrameScore f;
    f.id = id;
    f.dense = score_region(gt, e, opt.mode, nullptr);
    if (lidar_seeds) {
        const cv::Mat1b seeds = *lidar_seeds >= 0.0f;
        cv::Mat1b window;
        cv::dilate(seeds, window, cv::getStructuringElement(cv::MORPH_RECT, {opt.window, opt.window}));
        const cv::Mat1b window_only = window & ~seeds;
        f.has_lidar = true;
        f.n_seeds = cv::countNonZero(seeds);
        f.seeds = score_region(gt, e, opt.mode, &seeds);
        f.window = score_region(gt, e, opt.mode, &window);
        f.window_excl_seeds = score_region(gt, e, opt.mode, &window_only);
    }
    return f;
}

std::vector<ComponentScores> evaluate_masks(const GroundTruth &gt, const Estimate &est, FillMode mode,
                                            const std::vector<cv::Mat1b> &masks) {
    require(!gt.d0.empty(), ErrorCode::InvalidArgument, "ground truth d0 is empty");
    const cv::Size size = gt.d0.size();
    check_ground_truth(gt, size, "occ");
    check_estimate(est, size);
    for (const cv::Mat1b &m : masks)
        require(m.size() == size, ErrorCode::SizeMismatch, "region mask must be " + std::to_string(size.width) + "x" +
                                                                std::to_string(size.height));
    const Prepared e = prepare(est, mode);  // filled once for every mask
    std::vector<ComponentScores> out;
    out.reserve(masks.size());
    for (const cv::Mat1b &m : masks) out.push_back(score(gt, e, mode, &m));
    return out;
}

FrameScore evaluate_frame(const FrameGroundTruth &gt, const SceneFlowField &est, const EvalOptions &opt,
                          const DisparityMap *lidar_seeds, const std::string &id) {
    return evaluate_frame(gt, estimate_from_scene_flow(est), opt, lidar_seeds, id);
}

Summary summarize(const std::vector<FrameScore> &frames) {
    require(!frames.empty(), ErrorCode::InvalidArgument, "summarize: no frames");
    bool all_noc = true, all_lidar = true;
    for (const FrameScore &f : frames) {
        all_noc = all_noc && f.dense.has_noc;
        all_lidar = all_lidar && f.has_lidar;
    }
    Summary s;
    FrameScore &p = s.pooled;
    p.id = "pooled";
    p.dense.has_noc = all_noc;
    p.has_lidar = all_lidar;
    for (RegionScores *r : {&p.seeds, &p.window, &p.window_excl_seeds}) r->has_noc = all_noc && all_lidar;
    for (const FrameScore &f : frames) {
        add_region(p.dense, f.dense);
        if (!all_lidar) continue;
        p.n_seeds += f.n_seeds;
        add_region(p.seeds, f.seeds);
        add_region(p.window, f.window);
        add_region(p.window_excl_seeds, f.window_excl_seeds);
    }
    if (!all_noc) {
        p.dense.noc = {};
        for (RegionScores *r : {&p.seeds, &p.window, &p.window_excl_seeds}) r->noc = {};
    }
    s.mean_dense = mean_of(frames, &FrameScore::dense, all_noc);
    if (all_lidar) {
        s.mean_seeds = mean_of(frames, &FrameScore::seeds, all_noc);
        s.mean_window = mean_of(frames, &FrameScore::window, all_noc);
        s.mean_window_excl_seeds = mean_of(frames, &FrameScore::window_excl_seeds, all_noc);
    }
    return s;
}

}  // namespace lidarflow::eval
