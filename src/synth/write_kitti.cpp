// SPDX-License-Identifier: MIT
#include "synth/write_kitti.hpp"

#include <algorithm>
#include <cctype>

#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"

namespace lidarflow::synth {

std::string textureless_mask_path(const std::string &root, const std::string &id) {
    return root + "/masks/" + id + "_textureless.png";
}

std::string shadow_mask_path(const std::string &root, const std::string &id) {
    return root + "/masks/" + id + "_shadow.png";
}

void write_kitti(const SynthScene &scene, const std::string &root, const std::string &id) {
    require(id.size() == 6 && std::all_of(id.begin(), id.end(), [](unsigned char c) { return std::isdigit(c); }),
            ErrorCode::InvalidArgument, "write_kitti: frame id must be 6 digits, got '" + id + "'");
    require(!root.empty(), ErrorCode::InvalidArgument, "write_kitti: empty output folder");
    require(!scene.left0.empty() && !scene.right0.empty() && !scene.left1.empty() && !scene.right1.empty(),
            ErrorCode::InvalidArgument, "write_kitti: the scene has no images");
    const io::KittiLayout k{root};
    io::write_image(k.left(id, 0), scene.left0);
    io::write_image(k.left(id, 1), scene.left1);
    io::write_image(k.right(id, 0), scene.right0);
    io::write_image(k.right(id, 1), scene.right1);
    io::write_disparity_png(k.gt_disp0(id, true), scene.disp0_occ);
    io::write_disparity_png(k.gt_disp0(id, false), scene.disp0_noc);
    io::write_disparity_png(k.gt_disp1(id, true), scene.disp1_occ);
    io::write_disparity_png(k.gt_disp1(id, false), scene.disp1_noc);
    io::write_flow_png(k.gt_flow(id, true), scene.flow_occ);
    io::write_flow_png(k.gt_flow(id, false), scene.flow_noc);
    io::write_calib_cam_to_cam(k.calib_cam_to_cam(id), io::calib_from_camera(scene.camera));
    io::write_disparity_png(k.lidar(id, 0), scene.lidar0.to_map());
    io::write_disparity_png(k.lidar(id, 1), scene.lidar1.to_map());
    io::write_image(textureless_mask_path(root, id), scene.textureless_mask);
    io::write_image(shadow_mask_path(root, id), scene.shadow_mask);
}

}  // namespace lidarflow::synth
