// SPDX-License-Identifier: MIT
#include "eval/text_report.hpp"

#include <cmath>
#include <cstdio>
#include <string>

#include "eval/json_report.hpp"

namespace lidarflow::eval {
namespace {

std::string num(double v, int width, int prec = 2) {
    char buf[48];
    if (std::isfinite(v))
        std::snprintf(buf, sizeof buf, "%*.*f", width, prec, v);
    else
        std::snprintf(buf, sizeof buf, "%*s", width, "-");
    return buf;
}

std::string label(const std::string &s, int width) {
    std::string out = s;
    if (static_cast<int>(out.size()) < width) out.resize(width, ' ');
    return out;
}

// The four columns of one quantity, from either per-frame counts or frame means.
struct Row {
    double out[4], epe[3], dens[4];
};

Row row_of(const ComponentScores &c) {
    return {{c.d0.outlier_pct(), c.d1.outlier_pct(), c.fl.outlier_pct(), c.sf.outlier_pct()},
            {c.d0.epe(), c.d1.epe(), c.fl.epe()},
            {c.d0.density_pct(), c.d1.density_pct(), c.fl.density_pct(), c.sf.density_pct()}};
}

Row row_of(const ComponentMeans &m) {
    return {{m.d0.outlier_pct, m.d1.outlier_pct, m.fl.outlier_pct, m.sf.outlier_pct},
            {m.d0.epe, m.d1.epe, m.fl.epe},
            {m.d0.density_pct, m.d1.density_pct, m.fl.density_pct, m.sf.density_pct}};
}

void print_row(std::string &s, const std::string &name, const char *gt, const Row &r) {
    s += label(name, 16) + label(gt, 4);
    for (double v : r.out) s += num(v, 8);
    s += "  ";
    for (double v : r.epe) s += num(v, 8, 3);
    s += "  ";
    for (double v : r.dens) s += num(v, 8);
    s += '\n';
}

void print_region(std::string &s, const std::string &name, const RegionScores &r) {
    print_row(s, name, "occ", row_of(r.occ));
    if (r.has_noc) print_row(s, "", "noc", row_of(r.noc));
}

std::string table2_row(const std::string &name, const std::string &seeds, double a, double b, double c,
                       double d) {
    return label(name, 16) + label(seeds, 8) + num(a, 10) + num(b, 10) + num(c, 12) + num(d, 10) + '\n';
}

}  // namespace

std::string format_tables(const KittiEvaluation &ev) {
    std::string s;
    s += std::string("KITTI scene flow evaluation, mode ") + mode_name(ev.options.mode) +
         " (outlier: error > 3 px and > 5 % of ground truth)\n\n";
    s += label("frame", 16) + label("gt", 4) + "   ------- outliers [%] -------    ---- EPE [px] ----    ------- density [%] --------\n";
    s += label("", 20) + "      D0      D1      Fl      SF        D0      D1      Fl        D0      D1      Fl      SF\n";
    for (const FrameScore &f : ev.frames) print_region(s, f.id, f.dense);
    print_region(s, "pooled", ev.summary.pooled.dense);
    print_row(s, "mean/frame", "occ", row_of(ev.summary.mean_dense.occ));
    if (ev.summary.mean_dense.has_noc) print_row(s, "", "noc", row_of(ev.summary.mean_dense.noc));
    s += "pooled = counts summed over frames (KITTI devkit); mean/frame = per-frame values averaged.\n";

    if (ev.summary.pooled.has_lidar) {
        s += std::string("\nTable II: SF outliers [%] (occ ground truth) at LiDAR seeds, in the ") +
             std::to_string(ev.options.window) + "x" + std::to_string(ev.options.window) +
             " support windows (seeds included; without seeds beside), and dense\n";
        s += label("frame", 16) + label("seeds", 8) + "     Seeds    Window  Win-Seeds     Dense\n";
        for (const FrameScore &f : ev.frames)
            s += table2_row(f.id, std::to_string(f.n_seeds), f.seeds.occ.sf.outlier_pct(),
                            f.window.occ.sf.outlier_pct(), f.window_excl_seeds.occ.sf.outlier_pct(),
                            f.dense.occ.sf.outlier_pct());
        const FrameScore &p = ev.summary.pooled;
        s += table2_row("pooled", std::to_string(p.n_seeds), p.seeds.occ.sf.outlier_pct(),
                        p.window.occ.sf.outlier_pct(), p.window_excl_seeds.occ.sf.outlier_pct(),
                        p.dense.occ.sf.outlier_pct());
        const Summary &m = ev.summary;
        s += table2_row("mean/frame", "", m.mean_seeds.occ.sf.outlier_pct, m.mean_window.occ.sf.outlier_pct,
                        m.mean_window_excl_seeds.occ.sf.outlier_pct, m.mean_dense.occ.sf.outlier_pct);
    }
    return s;
}

}  // namespace lidarflow::eval
