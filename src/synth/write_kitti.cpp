// SPDX-License-Identifier: MIT
#include "synth/write_kitti.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/error.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/poses.hpp"
#include "io/velodyne.hpp"

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

std::string drive_frame_name(int k) {
    require(k >= 0, ErrorCode::InvalidArgument, "drive frame index must be >= 0");
    char buf[16];
    std::snprintf(buf, sizeof buf, "%010d", k);
    return buf;
}

namespace {

void write_text(const std::string &path, const std::string &text) {
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    std::ofstream out(path, std::ios::trunc);
    out << text;
    out.close();
    require(out.good(), ErrorCode::Io, "cannot write " + path);
}

}  // namespace

void write_drive_rig(const SynthConfig &config, const std::string &root) {
    io::write_calib_cam_to_cam(root + "/calib_cam_to_cam.txt", drive_calibration(config));
    const cv::Matx44d T = drive_velo_to_cam();
    std::string text = "calib_time: synthetic\nR:";
    char buf[64];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            std::snprintf(buf, sizeof buf, " %.17g", T(r, c));
            text += buf;
        }
    text += "\nT:";
    for (int r = 0; r < 3; ++r) {
        std::snprintf(buf, sizeof buf, " %.17g", T(r, 3));
        text += buf;
    }
    write_text(root + "/calib_velo_to_cam.txt", text + "\n");
}

void write_drive_timestamps(const std::string &root, int frames) {
    std::string text;
    char line[64];
    for (int k = 0; k < frames; ++k) {
        // KITTI raw's format; frames 0.1 s apart from an arbitrary start.
        const int tenths = k % 10, seconds = k / 10;
        std::snprintf(line, sizeof line, "2011-09-26 13:%02d:%02d.%d00000000\n", seconds / 60, seconds % 60, tenths);
        text += line;
    }
    for (const char *dir : {"image_02", "image_03", "velodyne_points"}) write_text(root + "/" + dir + "/timestamps.txt", text);
}

void write_drive_poses(const SynthConfig &config, const std::string &root, int frames) {
    std::vector<cv::Matx34d> poses;
    for (int k = 0; k < frames; ++k) poses.push_back(drive_camera_pose(config, k));
    write_text(root + "/gt/poses.txt", io::poses_text(poses, {}, io::PoseFormat::Kitti));
}

void write_drive_frame(const DriveFrame &frame, const std::string &root, int k) {
    require(!frame.left.empty() && !frame.right.empty() && !frame.scan.empty(), ErrorCode::InvalidArgument,
            "write_drive_frame: empty frame");
    const std::string name = drive_frame_name(k);
    io::write_image(root + "/image_02/data/" + name + ".png", frame.left);
    io::write_image(root + "/image_03/data/" + name + ".png", frame.right);
    io::write_velodyne_bin(root + "/velodyne_points/data/" + name + ".bin", frame.scan);
}

void write_drive_ground_truth(const SynthScene &pair, const std::string &root, int k) {
    require(!pair.disp0_occ.empty(), ErrorCode::InvalidArgument, "write_drive_ground_truth: no ground truth");
    const std::string file = "/" + drive_frame_name(k) + ".png";
    const std::string gt = root + "/gt/";
    io::write_disparity_png(gt + "disp_occ_0" + file, pair.disp0_occ);
    io::write_disparity_png(gt + "disp_noc_0" + file, pair.disp0_noc);
    io::write_disparity_png(gt + "disp_occ_1" + file, pair.disp1_occ);
    io::write_disparity_png(gt + "disp_noc_1" + file, pair.disp1_noc);
    io::write_flow_png(gt + "flow_occ" + file, pair.flow_occ);
    io::write_flow_png(gt + "flow_noc" + file, pair.flow_noc);
}

}  // namespace lidarflow::synth
