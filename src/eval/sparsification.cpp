// SPDX-License-Identifier: MIT
#include "eval/sparsification.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numeric>

#include "core/error.hpp"
#include "io/result_formats.hpp"

namespace lidarflow::eval {

Sparsification sparsify(const GroundTruth &gt, const Estimate &est, const cv::Mat1f &confidence, int steps) {
    require(steps >= 2, ErrorCode::InvalidArgument, "sparsification: steps must be >= 2");
    const cv::Size size = gt.d0.size();
    for (const cv::Size s : {gt.d1.size(), gt.flow.u.size(), est.d0.size(), est.d1.size(), est.flow.u.size(),
                             confidence.size()})
        require(s == size, ErrorCode::SizeMismatch, "sparsification: maps of different sizes");
    std::vector<float> conf;
    std::vector<unsigned char> outlier;
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            if (!disparity_valid(gt.d0(y, x)) || !disparity_valid(gt.d1(y, x)) || !gt.flow.valid(y, x)) continue;
            if (!disparity_valid(est.d0(y, x)) || !disparity_valid(est.d1(y, x)) || !est.flow.valid(y, x)) continue;
            const float c = confidence(y, x);
            conf.push_back(std::isfinite(c) ? c : -std::numeric_limits<float>::infinity());
            outlier.push_back(disparity_outlier(gt.d0(y, x), est.d0(y, x)) || disparity_outlier(gt.d1(y, x), est.d1(y, x)) ||
                              flow_outlier(gt.flow.u(y, x), gt.flow.v(y, x), est.flow.u(y, x), est.flow.v(y, x)));
        }
    require(!conf.empty(), ErrorCode::InvalidArgument, "sparsification: no pixel with ground truth and an estimate");
    std::vector<size_t> order(conf.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return conf[a] > conf[b]; });
    // kept_outliers[k]: outliers among the k most confident pixels.
    std::vector<long long> kept_outliers(order.size() + 1, 0);
    for (size_t i = 0; i < order.size(); ++i) kept_outliers[i + 1] = kept_outliers[i] + outlier[order[i]];
    const long long n = static_cast<long long>(order.size()), total = kept_outliers.back();
    Sparsification s;
    s.pixels = n;
    for (int k = 0; k < steps; ++k) {
        const double removed = static_cast<double>(k) / steps;
        const long long keep = std::max(1LL, static_cast<long long>(std::llround(static_cast<double>(n) * (1.0 - removed))));
        s.removed.push_back(removed);
        s.rate.push_back(100.0 * static_cast<double>(kept_outliers[static_cast<size_t>(keep)]) / static_cast<double>(keep));
        s.oracle.push_back(100.0 * static_cast<double>(std::max(0LL, total - (n - keep))) / static_cast<double>(keep));
    }
    s.area = std::accumulate(s.rate.begin(), s.rate.end(), 0.0) / steps;
    s.oracle_area = std::accumulate(s.oracle.begin(), s.oracle.end(), 0.0) / steps;
    const long long keep80 = std::max(1LL, static_cast<long long>(std::llround(0.8 * static_cast<double>(n))));
    const double rate80 = static_cast<double>(kept_outliers[static_cast<size_t>(keep80)]) / static_cast<double>(keep80);
    s.kept80_share = total > 0 ? rate80 / (static_cast<double>(total) / static_cast<double>(n)) : 0.0;
    return s;
}

cv::Mat1f load_confidence(const std::string &dir, const std::string &id) {
    std::string tried;
    for (const char *suffix : {"_10.npy", ".npy", "_10.pfm", ".pfm"}) {
        const std::string p = dir + "/confidence/" + id + suffix;
        tried += (tried.empty() ? "" : ", ") + p;
        if (!std::filesystem::is_regular_file(p)) continue;
        const cv::Mat m = p.compare(p.size() - 4, 4, ".npy") == 0 ? io::read_npy(p) : io::read_pfm(p);
        require(m.type() == CV_32FC1, ErrorCode::Format, p + ": a confidence map is one float32 channel");
        return m;
    }
    throw Error(ErrorCode::Io, "no confidence map for frame " + id + " (tried " + tried + ")");
}

std::string format_sparsification(const std::vector<std::string> &ids, const std::vector<Sparsification> &s) {
    if (s.empty()) return "";
    std::string out = "Sparsification (SF outliers [%] of the pixels kept when the least confident are removed "
                      "first; occ ground truth)\n\nframe     removed:";
    char buf[64];
    for (double r : s.front().removed) {
        std::snprintf(buf, sizeof buf, " %5.0f%%", 100.0 * r);
        out += buf;
    }
    out += "     area  oracle  kept 80 %\n";
    auto row = [&](const std::string &name, const std::vector<double> &v, double area, double oracle, double k80) {
        std::snprintf(buf, sizeof buf, "%-18s", name.c_str());
        out += buf;
        for (double x : v) {
            std::snprintf(buf, sizeof buf, " %6.2f", x);
            out += buf;
        }
        std::snprintf(buf, sizeof buf, "  %7.3f %7.3f %10.3f\n", area, oracle, k80);
        out += buf;
    };
    std::vector<double> mean(s.front().rate.size(), 0.0), mean_oracle = mean;
    double area = 0, oracle = 0, k80 = 0;
    for (size_t i = 0; i < s.size(); ++i) {
        row(ids[i], s[i].rate, s[i].area, s[i].oracle_area, s[i].kept80_share);
        row("  oracle", s[i].oracle, s[i].oracle_area, s[i].oracle_area, 0.0);
        for (size_t k = 0; k < mean.size(); ++k) {
            mean[k] += s[i].rate[k] / static_cast<double>(s.size());
            mean_oracle[k] += s[i].oracle[k] / static_cast<double>(s.size());
        }
        area += s[i].area / static_cast<double>(s.size());
        oracle += s[i].oracle_area / static_cast<double>(s.size());
        k80 += s[i].kept80_share / static_cast<double>(s.size());
    }
    row("mean/frame", mean, area, oracle, k80);
    out += "\narea: mean SF outlier rate over the curve; kept 80 %: the outlier rate of the 80 % most confident "
           "pixels over that of all (0 is a perfect ranking, 1 no better than chance)\n";
    return out;
}

}  // namespace lidarflow::eval
