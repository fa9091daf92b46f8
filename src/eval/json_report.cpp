// SPDX-License-Identifier: MIT
#include "eval/json_report.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace lidarflow::eval {
namespace {

// Minimal streaming writer: objects and arrays with comma handling, 2-space indentation.
class JsonWriter {
public:
    std::string str() const { return out_.str(); }

    void begin_object(const char *key = nullptr) { open(key, '{'); }
    void end_object() { close('}'); }
    void begin_array(const char *key = nullptr) { open(key, '['); }
    void end_array() { close(']'); }

    void value(const char *key, const std::string &s) {
        prefix(key);
        quoted(s);
    }
    void value(const char *key, int64_t v) {
        prefix(key);
        out_ << v;
    }
    // 17 significant digits round-trip a double; JSON has no NaN, so undefined is null.
    void value(const char *key, double v) {
        prefix(key);
        if (!std::isfinite(v)) {
            out_ << "null";
            return;
        }
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.17g", v);
        out_ << buf;
    }

private:
    void open(const char *key, char c) {
        prefix(key);
        out_ << c;
        first_ = true;
        ++depth_;
    }
    void close(char c) {
        --depth_;
        if (!first_) newline();
        out_ << c;
        first_ = false;
    }
    void prefix(const char *key) {
        if (depth_ > 0) {
            if (!first_) out_ << ',';
            newline();
        }
        first_ = false;
        if (key) {
            quoted(key);
            out_ << ": ";
        }
    }
    void newline() { out_ << '\n' << std::string(2 * depth_, ' '); }
    void quoted(const std::string &s) {
        out_ << '"';
        for (unsigned char c : s) {
            if (c == '"' || c == '\\') {
                out_ << '\\' << c;
            } else if (c < 0x20) {
                char buf[8];
                std::snprintf(buf, sizeof buf, "\\u%04x", c);
                out_ << buf;
            } else {
                out_ << c;
            }
        }
        out_ << '"';
    }

    std::ostringstream out_;
    int depth_ = 0;
    bool first_ = true;
};

void write_counts(JsonWriter &w, const char *key, const Counts &c, bool with_epe) {
    w.begin_object(key);
    w.value("outlier_pct", c.outlier_pct());
    if (with_epe) w.value("epe", c.epe());
    w.value("density_pct", c.density_pct());
    w.value("n_err", c.n_err);
    w.value("n_total", c.n_total);
    w.value("n_est", c.n_est);
    w.value("n_gt", c.n_gt);
    w.end_object();
}

void write_components(JsonWriter &w, const char *key, const ComponentScores &s) {
    w.begin_object(key);
    write_counts(w, "d0", s.d0, true);
    write_counts(w, "d1", s.d1, true);
    write_counts(w, "fl", s.fl, true);
    write_counts(w, "sf", s.sf, false);
    w.end_object();
}

void write_region(JsonWriter &w, const char *key, const RegionScores &r) {
    w.begin_object(key);
    write_components(w, "occ", r.occ);
    if (r.has_noc) write_components(w, "noc", r.noc);
    w.end_object();
}

void write_frame(JsonWriter &w, const char *key, const FrameScore &f) {
    w.begin_object(key);
    w.value("id", f.id);
    write_region(w, "dense", f.dense);
    if (f.has_lidar) {
        w.begin_object("lidar");
        w.value("n_seeds", f.n_seeds);
        write_region(w, "seeds", f.seeds);
        write_region(w, "window", f.window);
        write_region(w, "window_excl_seeds", f.window_excl_seeds);
        w.end_object();
    }
    w.end_object();
}

void write_mean(JsonWriter &w, const char *key, const MeanStat &m, bool with_epe) {
    w.begin_object(key);
    w.value("outlier_pct", m.outlier_pct);
    if (with_epe) w.value("epe", m.epe);
    w.value("density_pct", m.density_pct);
    w.value("frames_scored", static_cast<int64_t>(m.frames_scored));
    w.value("frames_with_gt", static_cast<int64_t>(m.frames_with_gt));
    w.end_object();
}

void write_mean_components(JsonWriter &w, const char *key, const ComponentMeans &m) {
    w.begin_object(key);
    write_mean(w, "d0", m.d0, true);
    write_mean(w, "d1", m.d1, true);
    write_mean(w, "fl", m.fl, true);
    write_mean(w, "sf", m.sf, false);
    w.end_object();
}

void write_mean_region(JsonWriter &w, const char *key, const RegionMeans &m) {
    w.begin_object(key);
    write_mean_components(w, "occ", m.occ);
    if (m.has_noc) write_mean_components(w, "noc", m.noc);
    w.end_object();
}

}  // namespace

const char *mode_name(FillMode mode) { return mode == FillMode::Filled ? "filled" : "est-only"; }

std::string to_json(const KittiEvaluation &ev) {
    JsonWriter w;
    w.begin_object();
    w.value("format", std::string("lidarflow-eval/1"));
    w.value("mode", std::string(mode_name(ev.options.mode)));
    w.value("window", static_cast<int64_t>(ev.options.window));
    w.begin_array("frames");
    for (const FrameScore &f : ev.frames) write_frame(w, nullptr, f);
    w.end_array();
    write_frame(w, "pooled", ev.summary.pooled);
    w.begin_object("mean_over_frames");
    write_mean_region(w, "dense", ev.summary.mean_dense);
    if (ev.summary.pooled.has_lidar) {
        write_mean_region(w, "seeds", ev.summary.mean_seeds);
        write_mean_region(w, "window", ev.summary.mean_window);
        write_mean_region(w, "window_excl_seeds", ev.summary.mean_window_excl_seeds);
    }
    w.end_object();
    w.end_object();
    return w.str() + "\n";
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

}  // namespace lidarflow::eval
