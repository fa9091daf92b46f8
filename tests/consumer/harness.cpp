// SPDX-License-Identifier: MIT
// Test harness of the installed-tree consumer check (install_check.sh), built in the main
// tree with the C++ core: it turns a KITTI-layout frame into the plain files the C consumer
// reads (the consumer stays free of PNG decoding), and the consumer's raw result back into
// KITTI PNGs written by the same writer as `lidarflow run`, so the two can be compared byte
// for byte.
//   harness to-raw ROOT ID DIR      DIR/{left0,right0,left1,right1}.ppm (P6 RGB or P5 gray),
//                                   DIR/lidar0.txt, lidar1.txt ("x y d" per line),
//                                   DIR/calib.txt ("fx fy cx cy baseline")
//   harness to-kitti DIR OUT ID     DIR/{size.txt,u,v,d0,d1.f32,valid.u8} -> OUT/{disp_0,disp_1,flow}/ID_10.png
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/lidar.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"
#include "io/kitti_submission.hpp"

namespace {

using namespace lidarflow;

void write_pnm(const std::string &path, const cv::Mat &image) {
    cv::Mat m = image;
    if (m.channels() == 3) cv::cvtColor(image, m, cv::COLOR_BGR2RGB);
    std::ofstream f(path, std::ios::binary);
    f << (m.channels() == 3 ? "P6" : "P5") << "\n" << m.cols << " " << m.rows << "\n255\n";
    for (int y = 0; y < m.rows; ++y) f.write(reinterpret_cast<const char *>(m.ptr(y)), m.cols * m.elemSize());
    require(f.good(), ErrorCode::Io, "cannot write " + path);
}

void write_lidar(const std::string &path, const SparseLidar &l) {
    std::FILE *f = std::fopen(path.c_str(), "w");
    require(f != nullptr, ErrorCode::Io, "cannot write " + path);
    // %.9g: every float survives the text round trip exactly.
    for (const LidarPoint &p : l.points) std::fprintf(f, "%d %d %.9g\n", p.x, p.y, static_cast<double>(p.disparity));
    std::fclose(f);
}

cv::Mat1f read_plane(const std::string &path, int w, int h) {
    cv::Mat1f m(h, w);
    std::ifstream f(path, std::ios::binary);
    f.read(reinterpret_cast<char *>(m.data), static_cast<std::streamsize>(m.total() * sizeof(float)));
    require(f.gcount() == static_cast<std::streamsize>(m.total() * sizeof(float)), ErrorCode::Format,
            path + " is too short");
    return m;
}

int to_raw(const std::string &root, const std::string &id, const std::string &dir) {
    const io::KittiLayout k{root};
    write_pnm(dir + "/left0.ppm", io::read_image(k.left(id, 0)));
    write_pnm(dir + "/right0.ppm", io::read_image(k.right(id, 0)));
    write_pnm(dir + "/left1.ppm", io::read_image(k.left(id, 1)));
    write_pnm(dir + "/right1.ppm", io::read_image(k.right(id, 1)));
    write_lidar(dir + "/lidar0.txt", SparseLidar::from_map(io::read_disparity_png(k.lidar(id, 0))));
    write_lidar(dir + "/lidar1.txt", SparseLidar::from_map(io::read_disparity_png(k.lidar(id, 1))));
    const StereoCamera c = io::read_calib_cam_to_cam(k.calib_cam_to_cam(id)).camera;
    std::ofstream f(dir + "/calib.txt");
    f.precision(17);
    f << c.fx << " " << c.fy << " " << c.cx << " " << c.cy << " " << c.baseline << "\n";
    require(f.good(), ErrorCode::Io, "cannot write " + dir + "/calib.txt");
    return 0;
}

int to_kitti(const std::string &dir, const std::string &out, const std::string &id) {
    int w = 0, h = 0;
    std::ifstream size(dir + "/size.txt");
    size >> w >> h;
    require(size && w > 0 && h > 0, ErrorCode::Format, dir + "/size.txt: expected 'W H'");
    SceneFlowField f;
    f.u = read_plane(dir + "/u.f32", w, h);
    f.v = read_plane(dir + "/v.f32", w, h);
    f.d0 = read_plane(dir + "/d0.f32", w, h);
    f.d1 = read_plane(dir + "/d1.f32", w, h);
    f.valid = cv::Mat1b(h, w);
    std::ifstream valid(dir + "/valid.u8", std::ios::binary);
    valid.read(reinterpret_cast<char *>(f.valid.data), static_cast<std::streamsize>(f.valid.total()));
    require(valid.gcount() == static_cast<std::streamsize>(f.valid.total()), ErrorCode::Format,
            dir + "/valid.u8 is too short");
    f.confidence = cv::Mat1f::zeros(h, w);
    io::write_submission(out, id, f);
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    try {
        const std::string cmd = argc > 1 ? argv[1] : "";
        if (cmd == "to-raw" && argc == 5) return to_raw(argv[2], argv[3], argv[4]);
        if (cmd == "to-kitti" && argc == 5) return to_kitti(argv[2], argv[3], argv[4]);
        std::fprintf(stderr, "usage: harness to-raw ROOT ID DIR | to-kitti DIR OUT ID\n");
        return 2;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "harness: %s\n", e.what());
        return 1;
    }
}
