// SPDX-License-Identifier: MIT
#pragma once
// File names of the official KITTI Scene Flow 2015 layout (training/ or a submission folder).
// Frame ids are 6-digit strings ("000002"); _10 is t0 and _11 is t1. Every path below checks
// its id first (check_id), so that no id ("../../x") names a file outside the layout.
#include <string>
#include <vector>

namespace lidarflow::io {

struct KittiLayout {
    std::string root;  // folder holding image_2/, disp_occ_0/, ... (or disp_0/, flow/ for results)

    std::string left(const std::string &id, int t) const { return file("image_2", id, t); }
    std::string right(const std::string &id, int t) const { return file("image_3", id, t); }
    // Ground truth; occ = all pixels, noc = non-occluded only.
    std::string gt_disp0(const std::string &id, bool occ = true) const {
        return file(occ ? "disp_occ_0" : "disp_noc_0", id, 0);
    }
    std::string gt_disp1(const std::string &id, bool occ = true) const {
        return file(occ ? "disp_occ_1" : "disp_noc_1", id, 0);
    }
    std::string gt_flow(const std::string &id, bool occ = true) const {
        return file(occ ? "flow_occ" : "flow_noc", id, 0);
    }
    // Foreground objects of the t0 frame (0 = background), used by the devkit's bg/fg split.
    std::string obj_map(const std::string &id) const { return file("obj_map", id, 0); }
    std::string calib_cam_to_cam(const std::string &id) const {
        return root + "/calib_cam_to_cam/" + checked(id) + ".txt";
    }
    std::string calib_velo_to_cam(const std::string &id) const {
        return root + "/calib_velo_to_cam/" + checked(id) + ".txt";
    }
    std::string velodyne(const std::string &id) const { return root + "/velodyne/" + checked(id) + ".bin"; }
    // The scan at t1, named like the t1 image. KITTI 2015 ships none (its velodyne/ID.bin is
    // the t0 scan); a layout built from KITTI raw, which has a scan per frame, can add it.
    std::string velodyne_t1(const std::string &id) const { return root + "/velodyne/" + checked(id) + "_11.bin"; }
    // Submission (estimate) layout, and the sparse LiDAR inputs written by sample-lidar.
    std::string est_disp0(const std::string &id) const { return file("disp_0", id, 0); }
    std::string est_disp1(const std::string &id) const { return file("disp_1", id, 0); }
    std::string est_flow(const std::string &id) const { return file("flow", id, 0); }
    std::string lidar(const std::string &id, int t) const { return file(t == 0 ? "lidar_0" : "lidar_1", id, 0); }

    // Every id with a left t0 image, sorted.
    std::vector<std::string> frame_ids() const { return ids_in("image_2"); }
    // Every id with an NNNNNN_10.png (N a digit) in root/folder, sorted; Io when the folder is
    // missing.
    std::vector<std::string> ids_in(const std::string &folder) const;

    static std::string file_in(const std::string &root, const std::string &folder, const std::string &id, int t) {
        return root + "/" + folder + "/" + checked(id) + (t == 0 ? "_10.png" : "_11.png");
    }

    // Throws Error(InvalidArgument) unless id is a frame id of the layout: exactly 6 ASCII
    // digits.
    static void check_id(const std::string &id);

private:
    static const std::string &checked(const std::string &id) {
        check_id(id);
        return id;
    }
    std::string file(const std::string &folder, const std::string &id, int t) const {
        return file_in(root, folder, id, t);
    }
};

}  // namespace lidarflow::io
