// SPDX-License-Identifier: MIT
#pragma once
// Writing a scene-flow result in the KITTI submission layout: OUT/disp_0/ID_10.png,
// OUT/disp_1/ID_10.png, OUT/flow/ID_10.png (devkit PNG codecs; invalid pixels stay invalid).
#include <string>

#include "core/maps.hpp"

namespace lidarflow::io {

// Splits the field into the devkit's three maps (pixels with valid = 0 become holes).
DisparityMap field_disparity0(const SceneFlowField &f);
DisparityMap field_disparity1(const SceneFlowField &f);
FlowField field_flow(const SceneFlowField &f);

// Creates the folders; throws Error(Io) when a file cannot be written, InvalidArgument for an
// empty field.
void write_submission(const std::string &out_root, const std::string &id, const SceneFlowField &f);

}  // namespace lidarflow::io
