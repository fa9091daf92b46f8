// SPDX-License-Identifier: MIT
#include "interpolation/edge_map.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/structured_edge_detection.hpp>

#include "core/error.hpp"
#include "io/storage_text.hpp"

namespace lidarflow::interpolation {

struct SedModel::Impl {
    cv::Ptr<cv::ximgproc::StructuredEdgeDetection> sed;
};

SedModel::SedModel(const std::string &path) {
    require(!path.empty(), ErrorCode::InvalidArgument, "SED model path is empty");
    {
        std::ifstream probe(path, std::ios::binary);
        require(probe.good() && std::filesystem::is_regular_file(path), ErrorCode::Io,
                "cannot open SED model file: " + path);
    }
    require(!io::xml_file_cut_short(path), ErrorCode::Format,
            "SED model: the XML ends before its last tag is closed (a truncated file?): " + path);
    // OpenCV builds its forest from whatever nodes it finds and would fail later (or crash) on
    // a file that is YAML but not a model, so the forest's nodes are checked here first.
    try {
        cv::FileStorage fs(path, cv::FileStorage::READ);
        require(fs.isOpened(), ErrorCode::Format, "SED model is not an OpenCV FileStorage file: " + path);
        for (const char *node : {"options", "thrs", "fids", "child", "segs", "nSegs", "eBins", "eBnds"})
            require(!fs[node].empty(), ErrorCode::Format,
                    std::string("SED model lacks the '") + node + "' node: " + path);
        auto impl = std::make_shared<Impl>();
        impl->sed = cv::ximgproc::createStructuredEdgeDetection(path);
        require(!impl->sed.empty(), ErrorCode::Format, "OpenCV rejected the SED model: " + path);
        impl_ = impl;
    } catch (const cv::Exception &e) {
        if (e.code == cv::Error::StsNoMem) throw;  // out of memory, not a bad file
        throw Error(ErrorCode::Format, "cannot load SED model " + path + ": " + e.what());
    }
}

cv::Mat1f SedModel::detect(const cv::Mat &image) const {
    require(!image.empty() && image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3),
            ErrorCode::InvalidArgument, "SED needs an 8-bit gray or BGR image");
    cv::Mat rgb, rgbf;
    if (image.channels() == 1)
        cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
    else
        cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
    rgb.convertTo(rgbf, CV_32FC3, 1.0 / 255.0);
    cv::Mat edges;
    try {
        impl_->sed->detectEdges(rgbf, edges);
    } catch (const cv::Exception &e) {
        if (e.code == cv::Error::StsNoMem) throw;
        throw Error(ErrorCode::Format, std::string("SED edge detection failed: ") + e.what());
    }
    cv::Mat1f out = edges;
    cv::min(cv::max(out, 0.0f), 1.0f, out);
    return out;
}

namespace {

// Colour gradient magnitude of a float image after Gaussian smoothing with sigma; multiplied
// by sigma so that a step edge answers alike at every scale (gamma-normalised derivative;
// on a pyramid level, both the derivative and sigma are in that level's pixels).
cv::Mat1f gradient_magnitude(const cv::Mat &imagef, double sigma) {
    cv::Mat smooth;
    cv::GaussianBlur(imagef, smooth, cv::Size(), sigma, sigma, cv::BORDER_REPLICATE);
    cv::Mat gx, gy;
    cv::Sobel(smooth, gx, CV_32F, 1, 0, 3, 0.125, 0, cv::BORDER_REPLICATE);
    cv::Sobel(smooth, gy, CV_32F, 0, 1, 3, 0.125, 0, cv::BORDER_REPLICATE);
    cv::Mat sq = gx.mul(gx) + gy.mul(gy);
    cv::Mat1f sum(imagef.rows, imagef.cols);
    if (sq.channels() == 1) {
        sq.copyTo(sum);
    } else {
        cv::transform(sq, sum, cv::Matx13f(1, 1, 1));
    }
    cv::sqrt(sum, sum);
    sum *= static_cast<float>(sigma);
    return sum;
}

// 90th percentile of a non-negative map, from a strided sample (exact order is not needed).
float percentile90(const cv::Mat1f &g) {
    std::vector<float> s;
    s.reserve(g.total() / 7 + 1);
    for (int y = 0; y < g.rows; y += 2)
        for (int x = y % 4 == 0 ? 0 : 1; x < g.cols; x += 3) s.push_back(g(y, x));
    if (s.empty()) return 0.0f;
    auto mid = s.begin() + static_cast<std::ptrdiff_t>(0.9 * static_cast<double>(s.size() - 1));
    std::nth_element(s.begin(), mid, s.end());
    return *mid;
}

}  // namespace

cv::Mat1f compute_edge_map(const cv::Mat &image, const EdgeMapOptions &o, const SedModel *sed) {
    require(!image.empty(), ErrorCode::InvalidArgument, "edge map: empty image");
    require(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3),
            ErrorCode::InvalidArgument, "edge map: image must be 8-bit gray or BGR");
    if (o.method == EdgeMethod::StructuredForest) {
        require(sed != nullptr, ErrorCode::InvalidArgument,
                "edge map: StructuredForest needs a loaded SED model (set sed_model_path)");
        return sed->detect(image);
    }
    require(std::isfinite(o.base_sigma) && o.base_sigma > 0.0f && o.base_sigma <= 16.0f,
            ErrorCode::InvalidArgument, "edge map: base_sigma must be in (0, 16]");
    require(std::isfinite(o.contrast_gain) && o.contrast_gain > 0.0f, ErrorCode::InvalidArgument,
            "edge map: contrast_gain must be > 0");

    cv::Mat src = image;
    if (o.bilateral_prefilter) {
        // Flattens road/foliage texture while keeping object boundaries: the gradients that
        // survive are mostly the ones SED would report.
        cv::Mat filtered;
        cv::bilateralFilter(image, filtered, 5, 25.0, 3.0, cv::BORDER_REPLICATE);
        src = filtered;
    }
    cv::Mat imagef;
    src.convertTo(imagef, image.channels() == 1 ? CV_32F : CV_32FC3, 1.0 / 255.0);

    cv::Mat1f g;
    if (o.method == EdgeMethod::Gradient) {
        g = gradient_magnitude(imagef, o.base_sigma);
    } else {
        // Coarser scales on a Gaussian pyramid: same response as blurring with 2 and 4 sigma
        // at full resolution, at a fraction of the cost.
        g = gradient_magnitude(imagef, o.base_sigma);
        cv::Mat level = imagef;
        for (int l = 1; l <= 2; ++l) {
            cv::Mat down;
            cv::pyrDown(level, down);
            level = down;
            cv::Mat1f gl = gradient_magnitude(level, o.base_sigma), up;
            cv::resize(gl, up, g.size(), 0, 0, cv::INTER_LINEAR);
            g += up;
        }
        g *= 1.0f / 3.0f;
    }
    const float p90 = std::max(percentile90(g), 1e-4f);
    const float scale = -1.0f / (o.contrast_gain * p90);
    cv::Mat1f e(g.rows, g.cols);
    for (int y = 0; y < g.rows; ++y) {
        const float *gr = g[y];
        float *er = e[y];
        for (int x = 0; x < g.cols; ++x) er[x] = 1.0f - std::exp(gr[x] * scale);
    }
    return e;
}

}  // namespace lidarflow::interpolation
