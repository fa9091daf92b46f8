// SPDX-License-Identifier: MIT
#include "matching/scene_flow_matcher.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include "core/error.hpp"
#include "matching/cost_cases.hpp"
#include "matching/descriptor_pyramid.hpp"
#include "matching/lidar_support.hpp"

namespace lidarflow::matching {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

uint64_t splitmix64(uint64_t &state) {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// Counter-based stream: identical numbers for a (seed, level, iteration, index) whatever the
// thread that draws them.
struct Rng {
    uint64_t state;
    Rng(uint64_t seed, int level, int iteration, int index) {
        state = seed ^ 0x5DEECE66Dull;
        uint64_t s = state;
        state ^= splitmix64(s) + static_cast<uint64_t>(level) * 0x100000001B3ull;
        s = state;
        state ^= splitmix64(s) + static_cast<uint64_t>(iteration + 7) * 0xC2B2AE3D27D4EB4Full;
        s = state;
        state ^= splitmix64(s) + static_cast<uint64_t>(index) * 0x165667B19E3779F9ull;
    }
    // Uniform integer in [-m, m].
    int sym(int m) { return static_cast<int>(splitmix64(state) % static_cast<uint64_t>(2 * m + 1)) - m; }
    // Uniform real in [0, hi].
    float uniform(float hi) {
        return hi * static_cast<float>((splitmix64(state) >> 11) * (1.0 / 9007199254740992.0));
    }
};

// Round half away from zero without a libm call (hot path).
inline int iround(float f) { return static_cast<int>(f + (f >= 0.0f ? 0.5f : -0.5f)); }

// One point per pixel; on duplicates the larger disparity (the nearer, visible surface) wins.
std::vector<LidarPoint> dedupe(const SparseLidar &l) {
    std::map<std::pair<int, int>, float> by_pixel;
    for (const LidarPoint &p : l.points) {
        auto key = std::make_pair(p.y, p.x);
        auto it = by_pixel.find(key);
        if (it == by_pixel.end() || p.disparity > it->second) by_pixel[key] = p.disparity;
    }
    std::vector<LidarPoint> out;
    out.reserve(by_pixel.size());
    for (const auto &kv : by_pixel) out.push_back({kv.first.second, kv.first.first, kv.second});
    return out;
}

// Everything one matcher shares between directions: validated LiDAR and the descriptor
// pyramids of the four images.
struct MatcherData : DescriptorPyramid {
    std::vector<LidarPoint> lidar[2];  // t0 (aligned to left0), t1 (aligned to left1)
};

// The PatchMatch of one direction. All per-seed arrays are allocated once up front.
class Engine {
public:
    struct State {
        float u = 0, v = 0, d0 = 0, d1 = 0;
    };

    Engine(const MatcherData &m, Direction dir);
    // Runs the levels from the next one not run yet down to `last` (coarse to fine); each
    // level's descriptors must exist when it runs.
    void run_levels(int last);
    MatchResult result() const;

private:
    struct SeedInfo {
        int x = 0, y = 0;    // full resolution
        int gx = -1, gy = -1;  // grid node; -1 for extra LiDAR seeds
        int lidar = -1;      // reference LiDAR point at this pixel (d0 fixed)
        int window = -1;     // nearest reference LiDAR point whose support window holds the seed
    };
    // The seeds one pyramid level works on: the grid nodes at multiples of `stride` plus every
    // extra LiDAR seed, their neighbour graph and the strips that partition them.
    struct Graph {
        int stride = 1;
        std::vector<char> active;           // per seed
        std::vector<int> seeds;             // active seeds
        std::vector<int> strip;             // per seed: strip index; -1 for extra or inactive seeds
        std::vector<int> nb_offset;         // n + 1: seed i's neighbours are nb[nb_offset[i], nb_offset[i + 1])
        std::vector<int> nb;
        std::vector<std::vector<int>> strip_seeds;  // row-major seed order within each strip
        // Strips a grid seed's neighbours lie within (1: adjacent ones; a LiDAR window's seed
        // may be further away). Strips more than `reach` apart never read each other's seeds.
        int reach = 1;
    };
    // A scored candidate: rounded positions in the four images and the term values.
    struct Scored {
        State s;
        int x1 = 0, y1 = 0, xr0 = 0, xr1 = 0;
        int cas = 0;
        float term[kNumTerms] = {};
        uint8_t have = 0;  // bit t: term[t] computed
        float cost = std::numeric_limits<float>::infinity();
    };

    void setup_seeds();
    void build_graph(Graph &g, int stride, const std::vector<int> &lidar_seed) const;
    int level_stride(int l) const;
    void activate(const Graph &coarse);
    void setup_level(int l);
    void init_coarsest();
    int target_hit(int i, const State &s) const;
    void prepare(int i, State cand, Scored &out, bool d1case, bool propagated = false) const;
    bool evaluate(int i, Scored &out, const Scored *reuse, float bound) const;
    void score(int i, const State &cand, Scored &out, bool d1case) const;
    bool try_candidate(int i, const State &cand, Scored &best, bool d1case, bool propagated = false) const;
    bool tried_before(int i, const Scored &s) const;
    void forget_tried(int i);
    bool process_seed(int i, int iteration, bool consider_all_in_strip);
    int run_strip(int strip, bool reverse, int iteration);
    int run_iteration(bool reverse, int iteration);
    void update_radii(int l);

    const MatcherData &m_;
    MatchingOptions opt_;  // a copy: the backward direction may use its own seed grid
    int slot_img_[4];  // slot -> physical image index
    const std::vector<LidarPoint> &ref_lidar_;
    const std::vector<LidarPoint> &tgt_lidar_;

    int gw_ = 0, gh_ = 0, num_grid_ = 0, xoff_ = 0, yoff_ = 0;
    std::vector<SeedInfo> info_;
    std::vector<Graph> graphs_;     // by increasing stride
    const Graph *graph_ = nullptr;  // the current level's
    std::vector<int> extra_seeds_;

    // Per level.
    int level_ = 0;
    float scale_ = 1;  // 2^-level
    int lw_ = 0, lh_ = 0;
    const features::DescriptorImage *desc_[4] = {nullptr, nullptr, nullptr, nullptr};
    std::vector<int> px_, py_;     // seed positions on the level
    cv::Mat1i tgt_labels_;         // D1 hits on the level
    std::vector<cv::Point> tgt_centre_;
    PatchShape shape_;
    const PatchCostFn cost_fn_ = patch_cost_kernel(opt_.sift.bits);  // the descriptors are computed with opt_.sift
    int next_level_ = 0;      // the next level run_levels runs
    int iteration_stamp_ = 0;  // iterations over all levels so far (strip_done_ values)
    double seconds_ = 0;      // spent in run_levels
    float penalty_ = 0, dmax_ = 0, max_r_ = 0;

    std::vector<Scored> best_;
    std::vector<int> visited_;
    // Lazy random search: whether seed n searches randomly on its next visit (set for every
    // seed when a level starts, then "its last visit improved it").
    std::vector<char> explore_;
    // Active set (exact): version_[n] counts the changes of seed n's match; seen_[k] is the
    // version of neighbour nb[k] (of the current level's graph) that its seed last tried. A neighbour whose match has
    // not changed since lost against a best that has only improved since (same cost formula),
    // so trying it again cannot win.
    std::vector<uint32_t> version_, seen_;
    std::vector<float> radius_, radius_d0_, radius_d1_;
    // Per strip: the iteration whose visit of the strip has finished (run_iteration).
    std::unique_ptr<std::atomic<int>[]> strip_done_;
    std::vector<int> strip_order_;  // run_iteration's claim order
    // Candidates tried before (exact): a candidate's cost depends only on its four image
    // positions, the case formula and the level, and a seed's best only improves while those
    // hold, so a position tuple the seed tried before cannot beat its best now. On 000002 (seed
    // 1) ~30 % of the candidates that reached evaluate() repeated one; a direct-mapped table of
    // kTriedSlots keys per seed catches ~80 % of them (32 slots 92 %, for twice the memory).
    static constexpr int kTriedSlots = 16;
    static constexpr uint64_t kNoKey = ~uint64_t{0};
    mutable std::vector<uint64_t> tried_;  // info_.size() * kTriedSlots keys
    mutable std::vector<uint32_t> skips_;  // per seed: candidates skipped as tried
};

Engine::Engine(const MatcherData &m, Direction dir)
    : m_(m), opt_(m.opt), ref_lidar_(dir == Direction::Forward ? m.lidar[0] : m.lidar[1]),
      tgt_lidar_(dir == Direction::Forward ? m.lidar[1] : m.lidar[0]),
      shape_(m.opt.patch_radius, m.opt.patch_step) {
    const bool fwd = dir == Direction::Forward;
    if (!fwd && opt_.backward_grid_step > 0) opt_.grid_step = opt_.backward_grid_step;
    slot_img_[kL0] = fwd ? 0 : 2;
    slot_img_[kR0] = fwd ? 1 : 3;
    slot_img_[kL1] = fwd ? 2 : 0;
    slot_img_[kR1] = fwd ? 3 : 1;
    setup_seeds();
    next_level_ = static_cast<int>(m_.levels.size()) - 1;
}

void Engine::setup_seeds() {
    const int W = m_.width, H = m_.height, step = opt_.grid_step;
    gw_ = std::max(1, W / step);
    gh_ = std::max(1, H / step);
    const int xoff = std::min(W - 1, (W - (gw_ - 1) * step) / 2);
    const int yoff = std::min(H - 1, (H - (gh_ - 1) * step) / 2);
    xoff_ = xoff;
    yoff_ = yoff;
    num_grid_ = gw_ * gh_;
    info_.assign(num_grid_, SeedInfo{});
    for (int gy = 0; gy < gh_; ++gy)
        for (int gx = 0; gx < gw_; ++gx) {
            SeedInfo &s = info_[gy * gw_ + gx];
            s.x = std::min(W - 1, gx * step + xoff);
            s.y = std::min(H - 1, gy * step + yoff);
            s.gx = gx;
            s.gy = gy;
        }

    // LiDAR seeds: a grid seed on a LiDAR pixel becomes that point's seed, others get their own.
    std::vector<int> lidar_seed(ref_lidar_.size(), -1);
    if (opt_.use_lidar) {
        for (int k = 0; k < static_cast<int>(ref_lidar_.size()); ++k) {
            const LidarPoint &p = ref_lidar_[k];
            const int gx = (p.x - xoff) / step, gy = (p.y - yoff) / step;
            if (p.x >= xoff && p.y >= yoff && gx < gw_ && gy < gh_ && (p.x - xoff) % step == 0 &&
                (p.y - yoff) % step == 0 && info_[gy * gw_ + gx].x == p.x && info_[gy * gw_ + gx].y == p.y) {
                info_[gy * gw_ + gx].lidar = k;
                lidar_seed[k] = gy * gw_ + gx;
            } else {
                SeedInfo s;
                s.x = p.x;
                s.y = p.y;
                s.lidar = k;
                lidar_seed[k] = static_cast<int>(info_.size());
                extra_seeds_.push_back(lidar_seed[k]);
                info_.push_back(s);
            }
        }
        // Support windows at full resolution: the same set of seeds on every level.
        if (opt_.support_window && !ref_lidar_.empty()) {
            std::vector<cv::Point2f> pts;
            for (const LidarPoint &p : ref_lidar_) pts.emplace_back(float(p.x), float(p.y));
            const cv::Mat1i lab = nearest_point_labels(pts, W, H, opt_.window_size / 2);
            for (SeedInfo &s : info_) s.window = s.lidar >= 0 ? s.lidar : lab(s.y, s.x);
        } else {
            for (SeedInfo &s : info_) s.window = s.lidar;
        }
    }

    // One graph per distinct stride of the pyramid.
    const int nlev = static_cast<int>(m_.levels.size());
    graphs_.clear();
    for (int l = 0; l < nlev; ++l) {
        const int stride = level_stride(l);
        if (!graphs_.empty() && graphs_.back().stride == stride) continue;
        graphs_.emplace_back();
        build_graph(graphs_.back(), stride, lidar_seed);
    }
    size_t max_strips = 0;
    for (const Graph &g : graphs_) max_strips = std::max(max_strips, g.strip_seeds.size());
    strip_done_ = std::make_unique<std::atomic<int>[]>(max_strips);
    for (size_t k = 0; k < max_strips; ++k) strip_done_[k].store(-1, std::memory_order_relaxed);  // iterations count from 0

    const size_t n = info_.size();
    best_.assign(n, Scored{});
    visited_.assign(n, -1);
    explore_.assign(n, 1);
    version_.assign(n, 0);
    radius_.assign(n, 0);
    radius_d0_.assign(n, 0);
    radius_d1_.assign(n, 0);
    if (opt_.remember_tried) {
        tried_.assign(n * kTriedSlots, kNoKey);
        skips_.assign(n, 0);
    }
    px_.assign(n, 0);
    py_.assign(n, 0);
}

// CPM keeps every seed on every level; coarse levels then hold many seeds per level pixel that
// all find the same match (3 px seeds are 3/8 px apart on the 1/8 level). From
// opt_.thin_from_level on, each coarser level keeps every second grid node per axis.
int Engine::level_stride(int l) const {
    const int k = l - opt_.thin_from_level + 1;
    int stride = k <= 0 ? 1 : 1 << std::min(k, 16);
    // Small images: keep enough seeds for the random initialisation to find every motion.
    auto nodes = [&](int s) { return static_cast<long>((gw_ + s - 1) / s) * ((gh_ + s - 1) / s); };
    while (stride > 1 && nodes(stride) < opt_.min_level_seeds) stride /= 2;
    return stride;
}

// Neighbour graph of one stride: 8-connected on the thinned grid, plus the window's LiDAR seed
// for window seeds; extra LiDAR seeds are linked to the 3x3 active nodes around them.
void Engine::build_graph(Graph &g, int stride, const std::vector<int> &lidar_seed) const {
    const int n = static_cast<int>(info_.size());
    g.stride = stride;
    g.active.assign(n, 0);
    g.seeds.clear();
    g.strip.assign(n, -1);
    g.nb_offset.assign(n + 1, 0);
    g.nb.clear();
    const int last_gx = (gw_ - 1) / stride * stride, last_gy = (gh_ - 1) / stride * stride;
    auto on_grid = [&](int i) { return info_[i].gx % stride == 0 && info_[i].gy % stride == 0; };
    for (int i = 0; i < n; ++i) {
        g.nb_offset[i] = static_cast<int>(g.nb.size());
        const SeedInfo &s = info_[i];
        const bool grid = i < num_grid_;
        if (grid && !on_grid(i)) continue;
        g.active[i] = 1;
        g.seeds.push_back(i);
        int cgx, cgy;
        if (grid) {
            cgx = s.gx;
            cgy = s.gy;
            g.strip[i] = s.gy / stride / opt_.strip_rows;
        } else {
            const float f = static_cast<float>(opt_.grid_step * stride);
            cgx = std::clamp(iround(float(s.x - xoff_) / f) * stride, 0, last_gx);
            cgy = std::clamp(iround(float(s.y - yoff_) / f) * stride, 0, last_gy);
        }
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const int nx = cgx + dx * stride, ny = cgy + dy * stride;
                if (nx < 0 || ny < 0 || nx >= gw_ || ny >= gh_) continue;
                const int k = ny * gw_ + nx;
                if (k != i) g.nb.push_back(k);
            }
        if (grid && s.window >= 0) {
            const int k = lidar_seed[s.window];
            if (k != i && (k >= num_grid_ || on_grid(k))) g.nb.push_back(k);
        }
    }
    g.nb_offset[n] = static_cast<int>(g.nb.size());
    const int rows = (gh_ - 1) / stride + 1;
    g.strip_seeds.assign((rows + opt_.strip_rows - 1) / opt_.strip_rows, {});
    for (int i : g.seeds)
        if (g.strip[i] >= 0) g.strip_seeds[g.strip[i]].push_back(i);
    g.reach = 1;
    for (int i : g.seeds) {
        if (g.strip[i] < 0) continue;
        for (int k = g.nb_offset[i]; k < g.nb_offset[i + 1]; ++k)
            if (g.strip[g.nb[k]] >= 0) g.reach = std::max(g.reach, std::abs(g.strip[g.nb[k]] - g.strip[i]));
    }
}

// Seeds that join on a finer level start from the nearest seed of the coarser one (its match
// and search radii); propagation then lets them pick a better neighbour's.
void Engine::activate(const Graph &coarse) {
    const int S = coarse.stride;
    const int last_gx = (gw_ - 1) / S * S, last_gy = (gh_ - 1) / S * S;
    for (int i : graph_->seeds) {
        if (coarse.active[i]) continue;
        const int gx = std::min(last_gx, (info_[i].gx + S / 2) / S * S);
        const int gy = std::min(last_gy, (info_[i].gy + S / 2) / S * S);
        const int d = gy * gw_ + gx;
        best_[i].s = best_[d].s;
        radius_[i] = radius_[d];
        radius_d0_[i] = radius_d0_[d];
        radius_d1_[i] = radius_d1_[d];
    }
}

void Engine::setup_level(int l) {
    level_ = l;
    scale_ = std::ldexp(1.0f, -l);
    {
        const int stride = level_stride(l);
        for (const Graph &g : graphs_)
            if (g.stride == stride) graph_ = &g;
        seen_.assign(graph_->nb.size(), 0);
    }
    const auto &lev = m_.levels[l];
    lw_ = lev.w;
    lh_ = lev.h;
    for (int s = 0; s < 4; ++s) desc_[s] = lev.desc[slot_img_[s]];
    for (size_t i = 0; i < info_.size(); ++i) {
        px_[i] = std::min(lw_ - 1, info_[i].x >> l);
        py_[i] = std::min(lh_ - 1, info_[i].y >> l);
    }
    penalty_ = opt_.out_of_image_penalty;
    dmax_ = opt_.max_disparity * scale_;
    max_r_ = std::max(1.0f, opt_.max_flow * scale_);
    tgt_centre_.clear();
    if (opt_.use_lidar && opt_.use_lidar1 && !tgt_lidar_.empty()) {
        std::vector<cv::Point2f> pts;
        for (const LidarPoint &p : tgt_lidar_) {
            pts.emplace_back(float(p.x) * scale_, float(p.y) * scale_);
            tgt_centre_.emplace_back(iround(pts.back().x), iround(pts.back().y));
        }
        const int r = opt_.support_window ? iround(float(opt_.window_size / 2) * scale_) : 0;
        tgt_labels_ = nearest_point_labels(pts, lw_, lh_, r);
    } else {
        tgt_labels_.release();
    }
}

// Index of the target LiDAR point whose (support window around its) pixel holds the flow
// target of state s, or -1.
int Engine::target_hit(int i, const State &s) const {
    if (tgt_labels_.empty()) return -1;
    const int x1 = px_[i] + iround(s.u), y1 = py_[i] + iround(s.v);
    if (x1 < 0 || y1 < 0 || x1 >= lw_ || y1 >= lh_) return -1;
    return tgt_labels_(y1, x1);
}

// Applies the LiDAR rules to a candidate and computes the cost of the given case, reusing terms
// of `reuse` whose image positions are unchanged. The D_l^1 case is decided per seed visit
// (from the seed's current match), not per candidate: candidates of one visit are compared with
// one formula, so no candidate wins merely because its target enters or leaves a D_l^1 window
// (the case formulas have different typical magnitudes).
void Engine::prepare(int i, State c, Scored &out, bool d1case, bool propagated) const {
    const SeedInfo &si = info_[i];
    const bool lidar = opt_.use_lidar;
    c.d0 = std::clamp(c.d0, 0.0f, dmax_);
    const float d0_before = c.d0;
    if (lidar && si.lidar >= 0) {
        c.d0 = ref_lidar_[si.lidar].disparity * scale_;  // never propagated into a LiDAR pixel
    } else if (lidar && opt_.const2 && si.window >= 0) {
        c.d0 = disparity_interval(ref_lidar_[si.window].disparity, opt_.const2_abs, opt_.const2_rel)
                   .clamp(c.d0 / scale_) * scale_;
    }
    // A neighbour's match keeps its disparity change when a LiDAR rule corrects its d0.
    c.d1 = d1_after_d0_rule(c.d1, d0_before, c.d0, propagated && opt_.keep_disparity_change);
    const int x0 = px_[i];
    const int x1 = x0 + iround(c.u), y1 = py_[i] + iround(c.v);
    c.d1 = std::clamp(c.d1, 0.0f, dmax_);
    {
        const int k = target_hit(i, c);
        if (k >= 0) {
            const float value = tgt_lidar_[k].disparity;
            if (tgt_centre_[k].x == x1 && tgt_centre_[k].y == y1)
                c.d1 = value * scale_;  // the target is the measured pixel itself
            else if (opt_.const2)
                c.d1 = disparity_interval(value, opt_.const2_abs, opt_.const2_rel).clamp(c.d1 / scale_) *
                       scale_;
        }
    }
    const bool d0case = lidar && (si.lidar >= 0 || (opt_.const1 && si.window >= 0));
    out.s = c;
    out.x1 = x1;
    out.y1 = y1;
    out.xr0 = x0 - iround(c.d0);
    out.xr1 = x1 - iround(c.d1);
    out.cas = (d0case ? 1 : 0) + (d1case ? 2 : 0);
    out.have = 0;
    out.cost = std::numeric_limits<float>::infinity();
}

bool Engine::evaluate(int i, Scored &out, const Scored *reuse, float bound) const {
    const int x0 = px_[i], y0 = py_[i];
    const int sx[4] = {x0, out.xr0, out.x1, out.xr1};
    const int sy[4] = {y0, y0, out.y1, out.y1};
    const float *w = case_weights(static_cast<CostCase>(out.cas), opt_.d1_terms);
    const float budget = bound * kCaseWeightSum[out.cas];
    float sum = 0;
    uint8_t pending = 0;
    // Terms whose two image positions did not move are taken from `reuse` first, so that the
    // remaining ones can stop as soon as the candidate cannot beat the bound.
    for (int t = 0; t < kNumTerms; ++t) {
        if (w[t] == 0) continue;
        const Slot a = kTermA[t], b = kTermB[t];
        if (reuse && (reuse->have >> t & 1)) {
            const int rsx[4] = {x0, reuse->xr0, reuse->x1, reuse->xr1};
            const int rsy[4] = {y0, y0, reuse->y1, reuse->y1};
            if (rsx[a] == sx[a] && rsy[a] == sy[a] && rsx[b] == sx[b] && rsy[b] == sy[b]) {
                out.term[t] = reuse->term[t];
                out.have |= static_cast<uint8_t>(1u << t);
                sum += w[t] * reuse->term[t];
                continue;
            }
        }
        pending |= static_cast<uint8_t>(1u << t);
    }
    for (int t = 0; t < kNumTerms; ++t) {
        if (!(pending >> t & 1)) continue;
        if (sum > budget) return false;
        const Slot a = kTermA[t], b = kTermB[t];
        const float e = cost_fn_(*desc_[a], *desc_[b], sx[a], sy[a], sx[b], sy[b], shape_, opt_.norm,
                                 penalty_, (budget - sum) / w[t]);
        sum += w[t] * e;
        if (sum > budget) return false;  // e may be partial: the candidate is rejected anyway
        out.term[t] = e;
        out.have |= static_cast<uint8_t>(1u << t);
    }
    out.cost = sum / kCaseWeightSum[out.cas];
    return true;
}

void Engine::score(int i, const State &c, Scored &out, bool d1case) const {
    prepare(i, c, out, d1case);
    evaluate(i, out, nullptr, std::numeric_limits<float>::infinity());
}

// Whether seed i tried candidate s's positions before (on this level, with this case formula);
// if not, s is recorded as tried. Positions that do not fit a key (offsets beyond +-8191 px,
// never on sane flows) are never skipped.
bool Engine::tried_before(int i, const Scored &s) const {
    if (tried_.empty()) return false;
    const int x0 = px_[i], y0 = py_[i];
    const int off[4] = {s.x1 - x0, s.y1 - y0, s.xr0 - x0, s.xr1 - s.x1};
    uint64_t key = static_cast<uint64_t>(level_) << 2 | static_cast<uint64_t>(s.cas);  // level < 16, cas < 4
    for (int o : off) {
        if (o < -8191 || o > 8191) return false;
        key = key << 14 | static_cast<uint64_t>(o + 8192);
    }
    // 62 bits, so never kNoKey; Fibonacci hashing picks the slot.
    static_assert(kTriedSlots == 16, "the slot is the hash's top 4 bits");
    uint64_t &slot = tried_[static_cast<size_t>(i) * kTriedSlots + ((key * 0x9E3779B97F4A7C15ull) >> 60)];
    if (slot == key) {
        ++skips_[i];
        return true;
    }
    slot = key;
    return false;
}

void Engine::forget_tried(int i) {
    if (tried_.empty()) return;
    std::fill_n(tried_.begin() + static_cast<ptrdiff_t>(i) * kTriedSlots, kTriedSlots, kNoKey);
}

bool Engine::try_candidate(int i, const State &cand, Scored &best, bool d1case, bool propagated) const {
    Scored s;
    prepare(i, cand, s, d1case, propagated);
    if (s.x1 == best.x1 && s.y1 == best.y1 && s.xr0 == best.xr0 && s.xr1 == best.xr1 && s.cas == best.cas)
        return false;  // same positions: same cost
    if (tried_before(i, s)) return false;
    if (evaluate(i, s, &best, best.cost) && s.cost < best.cost) {
        best = s;
        return true;
    }
    return false;
}

bool Engine::process_seed(int i, int iteration, bool consider_all_in_strip) {
    const SeedInfo &si = info_[i];
    const Graph &g = *graph_;
    Scored &best = best_[i];
    bool improved = false;
    const bool d1case = target_hit(i, best.s) >= 0;
    if (d1case != (best.cas >= 2)) {
        // Another cost formula: earlier comparisons say nothing about the new one.
        const State cur = best.s;
        score(i, cur, best, d1case);
        forget_tried(i);
        for (int k = g.nb_offset[i]; k < g.nb_offset[i + 1]; ++k) seen_[k] = version_[g.nb[k]] - 1;
    }
    // Propagation (constraint 1 everywhere; LiDAR rules applied inside score()).
    for (int k = g.nb_offset[i]; k < g.nb_offset[i + 1]; ++k) {
        const int n = g.nb[k];
        const bool fresh = consider_all_in_strip || g.strip[n] != g.strip[i] || g.strip[n] < 0 ||
                           visited_[n] == iteration;
        if (!fresh || seen_[k] == version_[n]) continue;
        seen_[k] = version_[n];
        improved |= try_candidate(i, best_[n].s, best, d1case, true);
    }
    // Random search with shrinking radius, separately for (u, v), d0 and d1.
    if (opt_.lazy_random_search && !improved && !explore_[i]) {
        visited_[i] = iteration;
        return false;
    }
    // Settled: no change since the last (failed) random search and no costlier than the
    // neighbours: skip the flow and d0 searches, keep d1's (matching_options.hpp, settle_ratio).
    bool settled = false;
    if (opt_.settle_ratio > 0 && !improved && !explore_[i]) {
        float sum = 0;
        int cnt = 0;
        for (int k = g.nb_offset[i]; k < g.nb_offset[i + 1]; ++k, ++cnt) sum += best_[g.nb[k]].cost;
        settled = cnt > 0 && best.cost * static_cast<float>(cnt) <= opt_.settle_ratio * sum;
    }
    Rng rng(opt_.random_seed, level_, iteration, i);
    if (!settled) {
        for (int mag = iround(radius_[i]); mag >= 1; mag /= 2) {
            State c = best.s;
            c.u += static_cast<float>(rng.sym(mag));
            c.v += static_cast<float>(rng.sym(mag));
            improved |= try_candidate(i, c, best, d1case);
        }
    }
    const bool d0_fixed = opt_.use_lidar && si.lidar >= 0;
    if (!d0_fixed && !settled) {
        for (int mag = iround(radius_d0_[i]); mag >= 1; mag /= 2) {
            State c = best.s;
            c.d0 += static_cast<float>(rng.sym(mag));
            improved |= try_candidate(i, c, best, d1case);
        }
    }
    for (int mag = iround(radius_d1_[i]); mag >= 1; mag /= 2) {
        State c = best.s;
        c.d1 += static_cast<float>(rng.sym(mag));
        improved |= try_candidate(i, c, best, d1case);
    }
    visited_[i] = iteration;
    if (improved) ++version_[i];
    explore_[i] = improved;
    return improved;
}

int Engine::run_strip(int strip, bool reverse, int iteration) {
    const std::vector<int> &seeds = graph_->strip_seeds[strip];
    int updates = 0;
    const int n = static_cast<int>(seeds.size());
    for (int k = 0; k < n; ++k) {
        const int i = seeds[reverse ? n - 1 - k : k];
        updates += process_seed(i, iteration, false) ? 1 : 0;
    }
    return updates;
}

namespace {

// Waits until another thread has stored `value` in `flag` (release), briefly spinning first.
void wait_for(const std::atomic<int> &flag, int value) {
    for (int spins = 0; flag.load(std::memory_order_acquire) != value; ++spins)
        if (spins >= 64) std::this_thread::yield();
}

}  // namespace

// One PatchMatch iteration over the strips of the level. The strips are coloured k mod
// (reach + 1) and visited colour by colour (in reverse colour order on reverse iterations), so
// strips of one colour never read each other's seeds and run in parallel, and each strip sees
// its neighbours of earlier colours as they are after this iteration's visit and those of
// later colours as they were before it. Instead of a barrier between colours, a strip waits
// only for its earlier-coloured strips within `reach` (results do not depend on the thread
// count or the timing): on 2 threads the barriers had left 7-14 % of the phases' thread time
// idle (the last strips of a colour running alone).
int Engine::run_iteration(bool reverse, int iteration) {
    const Graph &g = *graph_;
    const int num_strips = static_cast<int>(g.strip_seeds.size());
    const int colours = g.reach + 1;
    const auto phase = [&](int k) { return reverse ? colours - 1 - k % colours : k % colours; };
    strip_order_.clear();
    for (int c = 0; c < colours; ++c)
        for (int k = reverse ? colours - 1 - c : c; k < num_strips; k += colours) strip_order_.push_back(k);
    std::atomic<int> next{0};
    int updates = 0;
#pragma omp parallel num_threads(opt_.threads) reduction(+ : updates)
    for (int j; (j = next.fetch_add(1, std::memory_order_relaxed)) < num_strips;) {
        // Strips are claimed in colour order, so every strip waited for is claimed already and
        // itself waits only for earlier ones: no deadlock.
        const int k = strip_order_[j];
        for (int d = std::max(0, k - g.reach); d <= std::min(num_strips - 1, k + g.reach); ++d)
            if (phase(d) < phase(k)) wait_for(strip_done_[d], iteration);
        updates += run_strip(k, reverse, iteration);
        strip_done_[k].store(iteration, std::memory_order_release);
    }
    return updates;
}

void Engine::init_coarsest() {
    const int top = level_;
    const float init_r = max_r_;
    for (size_t i = 0; i < info_.size(); ++i) {
        Rng rng(opt_.random_seed, top, -1, static_cast<int>(i));
        State s;
        s.u = static_cast<float>(rng.sym(iround(init_r)));
        s.v = static_cast<float>(rng.sym(iround(init_r)));
        const SeedInfo &si = info_[i];
        if (opt_.use_lidar && opt_.support_window && si.window >= 0)
            s.d0 = ref_lidar_[si.window].disparity * scale_;
        else
            s.d0 = std::floor(rng.uniform(dmax_ + 0.999f));
        s.d1 = s.d0;
        radius_[i] = init_r;
        radius_d0_[i] = dmax_;
        radius_d1_[i] = dmax_;
        best_[i].s = s;
    }
}

// CPM: the next level searches within the spread of the neighbours' matches (x2 for the finer
// grid), at least 1 px.
void Engine::update_radii(int l) {
    const float maxr = std::max(1.0f, opt_.max_flow * std::ldexp(1.0f, -l));
    const float maxd = std::max(1.0f, opt_.max_disparity * std::ldexp(1.0f, -l));
    const Graph &g = *graph_;
    const int na = static_cast<int>(g.seeds.size());
    // Each seed writes only its own radii from matches nobody writes here: rows in parallel.
#pragma omp parallel for schedule(static) num_threads(opt_.threads)
    for (int a = 0; a < na; ++a) {
        const int i = g.seeds[a];
        const State &s = best_[i].s;
        float rf = 0, r0 = 0, r1 = 0;
        for (int k = g.nb_offset[i]; k < g.nb_offset[i + 1]; ++k) {
            const State &n = best_[g.nb[k]].s;
            rf = std::max(rf, std::hypot(n.u - s.u, n.v - s.v));
            r0 = std::max(r0, std::abs(n.d0 - s.d0));
            r1 = std::max(r1, std::abs(n.d1 - s.d1));
        }
        radius_[i] = std::clamp(rf, 1.0f, maxr) * 2.0f;
        radius_d0_[i] = std::clamp(r0, 1.0f, maxd) * 2.0f;
        radius_d1_[i] = std::clamp(r1, 1.0f, maxd) * 2.0f;
    }
}

void Engine::run_levels(int last) {
    const auto t0 = Clock::now();
    const int nlev = static_cast<int>(m_.levels.size());
    const int threads = opt_.threads;
    for (int l = next_level_; l >= last; --l) {
        const Graph *coarser = graph_;
        setup_level(l);
        const Graph &g = *graph_;
        const int na = static_cast<int>(g.seeds.size());
        if (l == nlev - 1) {
            init_coarsest();
        } else {
            if (coarser != graph_) activate(*coarser);
            for (int i : g.seeds) {
                State &s = best_[i].s;
                s.u *= 2;
                s.v *= 2;
                s.d0 *= 2;
                s.d1 *= 2;
            }
        }
#pragma omp parallel for schedule(static) num_threads(threads)
        for (int k = 0; k < na; ++k) {
            const int i = g.seeds[k];
            const State s = best_[i].s;
            score(i, s, best_[i], target_hit(i, s) >= 0);
        }
        // New level, new costs: every neighbour is worth one try.
#pragma omp parallel for schedule(static) num_threads(threads)
        for (int a = 0; a < na; ++a) {
            const int i = g.seeds[a];
            for (int k = g.nb_offset[i]; k < g.nb_offset[i + 1]; ++k) seen_[k] = version_[g.nb[k]] - 1;
        }
        std::fill(explore_.begin(), explore_.end(), 1);
        for (int it = 0; it < opt_.iterations; ++it) {
            const int stamp = iteration_stamp_++;
            const bool reverse = it % 2 == 1;
            int updates = run_iteration(reverse, stamp);
            const int ne = static_cast<int>(extra_seeds_.size());
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : updates)
            for (int k = 0; k < ne; ++k) updates += process_seed(extra_seeds_[k], stamp, true) ? 1 : 0;
            if (static_cast<float>(updates) < opt_.stop_ratio * static_cast<float>(na)) break;
        }
        if (l > 0) update_radii(l);
    }
    next_level_ = std::min(next_level_, last - 1);
    seconds_ += seconds_since(t0);
}

MatchResult Engine::result() const {
    const int n = static_cast<int>(info_.size());
    const int threads = opt_.threads;
    MatchResult r;
    r.seconds_matching = seconds_;
    r.grid_width = gw_;
    r.grid_height = gh_;
    for (uint32_t k : skips_) r.tried_skips += k;
    r.seeds.resize(n);
    for (int i = 0; i < n; ++i) {
        const State &s = best_[i].s;
        SeedMatch &o = r.seeds[i];
        o.x = info_[i].x;
        o.y = info_[i].y;
        o.u = s.u;
        o.v = s.v;
        o.d0 = s.d0;
        o.d1 = s.d1;
        o.cost = best_[i].cost;
        o.cost_case = static_cast<CostCase>(best_[i].cas);
        o.is_lidar = info_[i].lidar >= 0;
        o.in_window = info_[i].window >= 0;
    }
    const int W = m_.width, H = m_.height, step = opt_.grid_step;
    r.dense = SceneFlowField::uninitialized(W, H);  // put() below writes every pixel
    const int xoff = info_[0].x, yoff = info_[0].y;
    auto put = [&](int x, int y, int i) {
        const SeedMatch &o = r.seeds[i];
        r.dense.u(y, x) = o.u;
        r.dense.v(y, x) = o.v;
        r.dense.d0(y, x) = o.d0;
        r.dense.d1(y, x) = o.d1;
        r.dense.valid(y, x) = 1;
        r.dense.confidence(y, x) = 1.0f / (1.0f + std::max(0.0f, o.cost) / 100.0f);
    };
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < H; ++y) {
        const int gy = std::clamp(static_cast<int>(std::floor(float(y - yoff) / step + 0.5f)), 0, gh_ - 1);
        for (int x = 0; x < W; ++x) {
            const int gx = std::clamp(static_cast<int>(std::floor(float(x - xoff) / step + 0.5f)), 0, gw_ - 1);
            put(x, y, gy * gw_ + gx);
        }
    }
    for (int i : extra_seeds_) put(info_[i].x, info_[i].y, i);
    return r;
}

// The engine's result; its seconds count building it too.
MatchResult result_of(const Engine &e) {
    const auto t0 = Clock::now();
    MatchResult r = e.result();
    r.seconds_matching += seconds_since(t0);
    return r;
}

}  // namespace

struct SceneFlowMatcher::Impl : MatcherData {
    void require_usable() const {
        require(!levels.empty(), ErrorCode::InvalidArgument, "SceneFlowMatcher used after release_t0()");
    }
};

MatchResult SceneFlowMatcher::run(Direction dir) {
    Impl &m = *impl_;
    m.require_usable();
    m.describe_coarse(false);
    m.describe_full();
    Engine engine(m, dir);
    engine.run_levels(0);
    MatchResult r = result_of(engine);
    r.seconds_features = m.seconds_features;
    return r;
}

MatchPair SceneFlowMatcher::run_both() {
    Impl &m = *impl_;
    m.require_usable();
    m.describe_coarse(true);
    Engine fwd(m, Direction::Forward), bwd(m, Direction::Backward);
    fwd.run_levels(1);
    bwd.run_levels(1);
    m.release_coarse();
    m.describe_full();
    fwd.run_levels(0);
    bwd.run_levels(0);
    MatchPair r{result_of(fwd), result_of(bwd)};
    r.forward.seconds_features = r.backward.seconds_features = m.seconds_features;
    return r;
}

namespace {

// The matcher's checks of its input: options, the four images, the points.
void check_match_input(const MatchInput &in, const MatchingOptions &options) {
    options.validate();
    const cv::Mat *imgs[4] = {&in.left0, &in.right0, &in.left1, &in.right1};
    const char *names[4] = {"left0", "right0", "left1", "right1"};
    for (int i = 0; i < 4; ++i) {
        require(!imgs[i]->empty(), ErrorCode::InvalidArgument, std::string("MatchInput: ") + names[i] + " is empty");
        require(imgs[i]->depth() == CV_8U && (imgs[i]->channels() == 1 || imgs[i]->channels() == 3 ||
                                               imgs[i]->channels() == 4),
                ErrorCode::InvalidArgument,
                std::string("MatchInput: ") + names[i] + " must be 8-bit gray, BGR or BGRA");
        require(imgs[i]->size() == in.left0.size(), ErrorCode::SizeMismatch,
                std::string("MatchInput: ") + names[i] + " differs in size from left0");
    }
    require(in.left0.cols >= 2 && in.left0.rows >= 2, ErrorCode::InvalidArgument,
            "MatchInput: images must be at least 2x2");
    in.lidar0.validate(in.left0.cols, in.left0.rows, "MatchInput: lidar0");
    in.lidar1.validate(in.left0.cols, in.left0.rows, "MatchInput: lidar1");
}

}  // namespace

std::shared_ptr<const StereoFeatures> stereo_features(const cv::Mat &left, const cv::Mat &right,
                                                      const MatchingOptions &options) {
    const SparseLidar none{left.cols, left.rows, {}};
    check_match_input(MatchInput{left, right, left, right, none, none}, options);
    auto p = std::make_shared<StereoFeatures>();
    p->left = left.clone();
    p->right = right.clone();
    p->sift = options.sift;
    describe_pairs({p.get()}, options);
    return p;
}

SceneFlowMatcher::SceneFlowMatcher(const MatchInput &in, const MatchingOptions &options,
                                   std::shared_ptr<const StereoFeatures> reuse_t0,
                                   std::shared_ptr<StereoFeatures> storage)
    : impl_(std::make_unique<Impl>()) {
    check_match_input(in, options);
    Impl &m = *impl_;
    m.opt = options;
    m.width = in.left0.cols;
    m.height = in.left0.rows;
    if (options.use_lidar) {
        m.lidar[0] = dedupe(in.lidar0);
        m.lidar[1] = dedupe(in.lidar1);
    }

    m.init(in, std::move(reuse_t0), std::move(storage));
}

SceneFlowMatcher::~SceneFlowMatcher() = default;

double SceneFlowMatcher::seconds_features() const { return impl_->seconds_features; }

std::shared_ptr<const StereoFeatures> SceneFlowMatcher::features_t1() {
    impl_->require_usable();
    impl_->describe_full();
    return impl_->pair[1];
}

bool SceneFlowMatcher::reused_t0() const { return impl_->reused_t0; }

std::shared_ptr<StereoFeatures> SceneFlowMatcher::release_t0() {
    std::shared_ptr<const StereoFeatures> t0 = std::move(impl_->pair[0]);
    impl_->levels.clear();
    impl_->pending[0] = impl_->pending[1] = nullptr;
    impl_->release_coarse();
    if (!t0 || t0.use_count() != 1) return nullptr;
    // Every pair is created non-const (make_shared above); the const of pair[] only says that
    // matching reads it. The sole owner may therefore hand it on for writing.
    return std::const_pointer_cast<StereoFeatures>(t0);
}

MatchResult match_scene_flow(const MatchInput &input, const MatchingOptions &options, Direction direction) {
    SceneFlowMatcher matcher(input, options);
    return matcher.run(direction);
}

}  // namespace lidarflow::matching
