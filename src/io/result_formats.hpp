// SPDX-License-Identifier: MIT
#pragma once
// Result files other than KITTI's 16-bit PNGs, for tools that expect float maps:
//  - .flo (Middlebury): optical flow, written and read by OpenCV's writeOpticalFlow /
//    readOpticalFlow. Invalid pixels hold 1e10 in u and v: Middlebury readers treat any
//    |value| > 1e9 as unknown flow.
//  - .pfm (Portable Float Map): "Pf" (1 channel) or "PF" (3 channels), little-endian float32
//    (scale -1), rows stored bottom to top as the format demands.
//  - .npy (NumPy v1.0): '<f4', C order, shape (H, W), (H, W, 2) or (H, W, 3); '|u1' (H, W).
// In .pfm and .npy an invalid value is NaN (docs/CONVENTIONS.md). .npy flow is (H, W, 2) u, v as
// OpenCV and numpy users hold it, with validity in a uint8 (H, W) file of its own; .pfm has no
// two-channel form, so its flow is (u, v, valid) per pixel like KITTI's flow PNG.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/maps.hpp"

namespace lidarflow::io {

enum class ResultFormat { Kitti, Flo, Pfm, Npy };

// "kitti", "flo", "pfm", "npy"; parse throws Error(InvalidArgument) naming the accepted ones.
const char *result_format_name(ResultFormat f);
ResultFormat parse_result_format(const std::string &name);

// Output names. A KITTI frame id (6 digits) names files ID_10.EXT as KITTI does; any other name
// (1 to 128 of A-Z a-z 0-9 _ - ., not . or ..) names them NAME.EXT. check_output_name throws
// Error(InvalidArgument) for another name; result_file_stem checks, then gives "ID_10" or NAME.
void check_output_name(const std::string &name);
std::string result_file_stem(const std::string &name);
// The output name for an input image: its file stem, the frame id for a KITTI image name
// (image_2/000002_10.png -> 000002), characters outside the set above replaced by '_'.
std::string output_name_from_path(const std::string &path);

// Writes OUT/disp_0/STEM.EXT, OUT/disp_1/STEM.EXT and OUT/flow/STEM.EXT (STEM =
// result_file_stem(id); creating the folders) and returns the paths. kitti: the devkit PNGs (write_submission); pfm, npy: as above,
// npy also OUT/valid/STEM.npy (uint8, 1 where u, v, d0, d1 are defined; fourth path); npy and
// pfm also OUT/confidence/STEM.npy|pfm (confidence_map; the last path);
// flo: the flow as .flo and, since .flo has no one-channel form, the disparities as .pfm.
// Throws Error: InvalidArgument for an empty field, Io when a file cannot be written.
std::vector<std::string> write_results(const std::string &out_root, const std::string &id, const SceneFlowField &f,
                                       ResultFormat format);
// The confidence plane with 0 where the field is not valid (float32).
cv::Mat1f confidence_map(const SceneFlowField &f);
// The paths write_results writes for `format` (disp_0, disp_1, flow, then valid and confidence
// for npy, confidence for pfm), without writing.
// Throws like check_output_name.
std::vector<std::string> result_paths(const std::string &out_root, const std::string &id, ResultFormat format);

// CV_32FC1 or CV_32FC3 maps (write_npy also CV_32FC2 and CV_8UC1). Writers create missing parent folders and throw Error: Io when the
// file cannot be written, InvalidArgument for an empty map or another type. Readers throw Io
// when the file cannot be read and Format for anything but the float32 layouts above (a
// big-endian PFM is accepted; read_npy also takes (H, W, 2) and uint8 (H, W)), for a side larger than
// kMaxImageSide, or for a file whose size differs from what its header announces: checked
// before anything is allocated.
void write_pfm(const std::string &path, const cv::Mat &map);
cv::Mat read_pfm(const std::string &path);
void write_npy(const std::string &path, const cv::Mat &map);
cv::Mat read_npy(const std::string &path);

// .flo as OpenCV's writeOpticalFlow writes it; unknown flow (|u| or |v| > 1e9) reads back as
// valid = 0. read_flo checks the header and the file size like the readers above.
void write_flo(const std::string &path, const FlowField &flow);
FlowField read_flo(const std::string &path);

// Any file `write_results` writes, by its extension (case-insensitive): a disparity map from
// .png (KITTI), .pfm or .npy (one channel; NaN = invalid); a flow field from .png (KITTI),
// .flo, .pfm or .npy ((u, v, valid) or (u, v), NaN = invalid). Format for another extension.
DisparityMap read_disparity_file(const std::string &path);
FlowField read_flow_file(const std::string &path);

// The float maps written for a field: disparity with NaN holes, flow as (u, v, valid) or as
// (u, v) with NaN holes.
cv::Mat1f disparity_with_nan(const DisparityMap &disp);
cv::Mat3f flow_with_valid(const FlowField &flow);
cv::Mat2f flow_with_nan(const FlowField &flow);

}  // namespace lidarflow::io
