// SPDX-License-Identifier: MIT
#pragma once
// Soft edge map of the reference image I_l^0, the cost layer of the geodesic distance that
// makes interpolation neighbourhoods stop at image boundaries (paper: Structured Edge
// Detection, SED). SED's trained forest ships with no Debian package, so a built-in detector
// is the default and a user-supplied SED model (OpenCV ximgproc .yml/.yml.gz) is optional.
#include <memory>
#include <string>

#include <opencv2/core.hpp>

namespace lidarflow::interpolation {

enum class EdgeMethod {
    // Colour gradient magnitude at one scale (Gaussian sigma = base_sigma). Cheapest.
    Gradient,
    // Mean of the colour gradient magnitude at three scales (sigma, 2 sigma, 4 sigma): fine
    // texture answers only at the finest scale, object boundaries at all of them, so texture
    // is damped relative to boundaries, which is what SED is trained to do.
    MultiScaleGradient,
    // Structured Edge Detection with the model at EdgeMapOptions::sed_model_path.
    StructuredForest,
};

struct EdgeMapOptions {
    EdgeMethod method = EdgeMethod::MultiScaleGradient;
    float base_sigma = 1.0f;      // Gaussian pre-smoothing of the finest scale [px], > 0
    bool bilateral_prefilter = true;  // flatten texture before the gradients (built-in methods)
    // Response at which a gradient counts as a "full" edge, relative to the image's 90th
    // gradient percentile; the soft map is 1 - exp(-g / (gain * p90)). > 0.
    float contrast_gain = 2.0f;
    std::string sed_model_path;  // required for StructuredForest, ignored otherwise
};

// Loaded SED forest; loading takes ~1 s, so keep one per interpolator, not per frame.
// Thread safety: detect() is const and may be called from several threads.
class SedModel {
public:
    // Throws Error(Io) when the file cannot be opened, Error(Format) when it is not an
    // OpenCV SED model (missing forest nodes, or OpenCV rejects it).
    explicit SedModel(const std::string &path);
    // Edge probabilities in [0, 1] of an 8-bit BGR or gray image (same size, CV_32F).
    cv::Mat1f detect(const cv::Mat &image) const;

private:
    struct Impl;
    std::shared_ptr<const Impl> impl_;
};

// Soft edge map in [0, 1] (CV_32F, image size) of an 8-bit 1- or 3-channel image. `sed` is
// used (and required) only for EdgeMethod::StructuredForest; borrowed for the call.
// Throws Error(InvalidArgument) on an empty/unsupported image, bad options or a missing model.
cv::Mat1f compute_edge_map(const cv::Mat &image, const EdgeMapOptions &options,
                           const SedModel *sed = nullptr);

}  // namespace lidarflow::interpolation
