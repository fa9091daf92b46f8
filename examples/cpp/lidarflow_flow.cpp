// SPDX-License-Identifier: MIT
// lidarflow from C++ with OpenCV: scene flow of stereo frame pairs, written as Middlebury .flo
// files by cv::writeOpticalFlow. Uses only <lidarflow/lidarflow.hpp> and OpenCV.
//
//   lidarflow_flow --root DIR [--out DIR] [--preset NAME] [--threads N]
//       KITTI scene flow 2015 frames 000002 and 000003 of DIR (a training/ folder:
//       image_2/, image_3/, calib_cam_to_cam/, calib_velo_to_cam/, velodyne/): each ID_10 ->
//       ID_11 pair with the Velodyne scan of ID_10 (and of ID_11 where velodyne/ID_11.bin
//       exists), written to OUT/ID_10.flo; where flow_occ/ID_10.png is there, the flow is
//       compared with it (KITTI's Fl outlier rate).
//   lidarflow_flow [--out DIR] [--preset NAME] [--threads N]
//       the built-in synthetic scene: a textured wall 5 m ahead that slides 4 px to the right,
//       with a row of LiDAR returns; written to OUT/synthetic.flo.
//
// Build against an installed lidarflow (examples/cpp/CMakeLists.txt does the same with CMake):
//   c++ -std=c++17 lidarflow_flow.cpp $(pkg-config --cflags --libs lidarflow opencv4) -o lidarflow_flow
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/video/tracking.hpp>  // cv::writeOpticalFlow, cv::readOpticalFlow

#include <lidarflow/lidarflow.hpp>

namespace {

struct Args {
    std::string root, out = ".", preset = "default";
    int threads = 2;
};

bool exists(const std::string &path) { return std::filesystem::exists(path); }

// A KITTI Velodyne scan: little-endian float32 (x, y, z, reflectance) records, one per row.
cv::Mat read_velodyne(const std::string &path) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) throw std::runtime_error("cannot read " + path);
    const std::streamsize bytes = f.tellg();
    if (bytes % 16 != 0) throw std::runtime_error(path + ": not a list of 16-byte records");
    cv::Mat scan(static_cast<int>(bytes / 16), 4, CV_32FC1);
    f.seekg(0);
    f.read(reinterpret_cast<char *>(scan.data), bytes);
    return scan;
}

cv::Mat read_image(const std::string &path) {
    // 8-bit gray or BGR, as lidarflow takes them; KITTI's colour PNGs come as BGR.
    cv::Mat m = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (m.empty()) throw std::runtime_error("cannot read " + path);
    return m;
}

// KITTI's Fl: share of ground-truth pixels whose end-point error exceeds 3 px and 5 % of the
// true flow. KITTI flow PNGs: 16-bit (u, v, valid) read by OpenCV as (valid, v, u).
double kitti_fl(const cv::Mat &flow, const std::string &gt_path, std::size_t &count) {
    const cv::Mat gt = cv::imread(gt_path, cv::IMREAD_UNCHANGED);
    if (gt.type() != CV_16UC3 || gt.size() != flow.size()) throw std::runtime_error(gt_path + ": not a KITTI flow map");
    std::size_t bad = 0;
    count = 0;
    for (int y = 0; y < gt.rows; ++y)
        for (int x = 0; x < gt.cols; ++x) {
            const cv::Vec3w g = gt.at<cv::Vec3w>(y, x);
            if (g[0] == 0) continue;
            const double gu = (g[2] - 32768.0) / 64.0, gv = (g[1] - 32768.0) / 64.0;
            const cv::Vec2f f = flow.at<cv::Vec2f>(y, x);
            const double err = std::hypot(f[0] - gu, f[1] - gv);  // NaN (no estimate) counts as bad
            ++count;
            bad += !(err <= 3.0 || err <= 0.05 * std::hypot(gu, gv));
        }
    return count != 0 ? 100.0 * static_cast<double>(bad) / static_cast<double>(count) : 0.0;
}

void write_flow(const std::string &path, const cv::Mat &flow) {
    if (!cv::writeOpticalFlow(path, flow)) throw std::runtime_error("cannot write " + path);
    // Read back: the file holds exactly the estimator's CV_32FC2 flow.
    const cv::Mat back = cv::readOpticalFlow(path);
    if (back.type() != CV_32FC2 || back.size() != flow.size() || cv::norm(back, flow, cv::NORM_INF) != 0)
        throw std::runtime_error(path + " does not read back");
}

lidarflow::Options make_options(const Args &a) {
    lidarflow::Options opt = lidarflow::Options::preset(a.preset);  // the preset first, then the rest
    opt.set("threads", a.threads);
    return opt;
}

int run_kitti(const Args &a) {
    for (const std::string id : {"000002", "000003"}) {
        const std::string r = a.root + "/";
        // Camera and Velodyne -> rectified left camera transform from KITTI's calibration files.
        const auto calib = lidarflow::Calibration::read_kitti(r + "calib_cam_to_cam/" + id + ".txt",
                                                              r + "calib_velo_to_cam/" + id + ".txt");
        lidarflow::Estimator est(calib, make_options(a));
        const cv::Mat scan0 = read_velodyne(r + "velodyne/" + id + ".bin");
        est.push(0, read_image(r + "image_2/" + id + "_10.png"), read_image(r + "image_3/" + id + "_10.png"),
                 lidarflow::LidarView::from_mat(lidarflow::LidarKind::points_lidar, scan0));
        // KITTI 2015 ships the scan of the first frame only; a layout made from KITTI raw may add ID_11.bin.
        const cv::Mat left1 = read_image(r + "image_2/" + id + "_11.png"),
                      right1 = read_image(r + "image_3/" + id + "_11.png");
        const std::string scan1_path = r + "velodyne/" + id + "_11.bin";
        if (exists(scan1_path)) {
            const cv::Mat scan1 = read_velodyne(scan1_path);
            est.push(100000, left1, right1, lidarflow::LidarView::from_mat(lidarflow::LidarKind::points_lidar, scan1));
        } else {
            est.push(100000, left1, right1);
        }

        const cv::Mat flow = est.flow();  // CV_32FC2, NaN where not valid (none: the result is dense)
        const std::string out = a.out + "/" + id + "_10.flo";
        write_flow(out, flow);
        std::printf("%s: %dx%d flow in %.1f s -> %s", id.c_str(), flow.cols, flow.rows, est.info().total_seconds,
                    out.c_str());
        const std::string gt = r + "flow_occ/" + id + "_10.png";
        if (exists(gt)) {
            std::size_t n = 0;
            const double fl = kitti_fl(flow, gt, n);
            std::printf(", Fl %.2f %% of %zu ground-truth pixels", fl, n);
        }
        std::printf("\n");
    }
    return 0;
}

int run_synthetic(const Args &a) {
    constexpr int W = 320, H = 96, DISP = 12, MOVE = 4;
    // Texture of the wall at wall coordinate (x, y); a point at left x is at x - DISP right.
    auto wall = [](int x, int y) {
        uint32_t h = static_cast<uint32_t>(x / 2 + 1000) * 374761393u +
                     static_cast<uint32_t>(y / 2 + 1000) * 668265263u;
        h = (h ^ (h >> 13)) * 1274126177u;
        return static_cast<uint8_t>(h >> 24);
    };
    auto render = [&](int move, cv::Mat &left, cv::Mat &right) {
        left.create(H, W, CV_8UC1);
        right.create(H, W, CV_8UC1);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                left.at<uint8_t>(y, x) = wall(x - move, y);
                right.at<uint8_t>(y, x) = wall(x + DISP - move, y);
            }
    };
    // fx * baseline / depth = 300 px * 0.2 m / 5 m = 12 px of disparity.
    lidarflow::Estimator est(lidarflow::Calibration::pinhole(300, 300, W / 2.0, H / 2.0, 0.2), make_options(a));
    // LiDAR returns as sparse disparities (column, row, d).
    using lidarflow::LidarKind;
    using lidarflow::LidarView;
    std::vector<float> lidar;
    for (int i = 0; i < 8; ++i) lidar.insert(lidar.end(), {20.0f + 40.0f * i, H / 2.0f, float(DISP)});
    cv::Mat left, right;
    for (int frame = 0; frame < 2; ++frame) {
        render(frame * MOVE, left, right);  // the estimator copies the images: buffers are reusable
        est.push(frame * 100000, left, right, LidarView::from_vector(LidarKind::disparity, lidar));
    }
    const cv::Mat flow = est.flow(), d0 = est.disparity0();
    const std::string out = a.out + "/synthetic.flo";
    write_flow(out, flow);
    const cv::Scalar mean_flow = cv::mean(flow), mean_d0 = cv::mean(d0);
    std::printf("lidarflow %s (C++): mean flow u %.2f px (truth %d), mean disparity %.2f px (truth %d) -> %s\n",
                lidarflow::version_string().c_str(), mean_flow[0], MOVE, mean_d0[0], DISP, out.c_str());
    return std::fabs(mean_flow[0] - MOVE) < 0.5 && std::fabs(mean_d0[0] - DISP) < 0.5 ? 0 : 1;
}

}  // namespace

int main(int argc, char **argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        const std::string k = argv[i];
        if (k == "--help" || k == "-h") {
            std::printf("usage: %s [--root KITTI_TRAINING_DIR] [--out DIR] [--preset default|balanced|fast] "
                        "[--threads N]\n",
                        argv[0]);
            return 0;
        }
        if (i + 1 >= argc) {
            std::fprintf(stderr, "%s: %s needs a value (--help)\n", argv[0], k.c_str());
            return 2;
        }
        const std::string v = argv[++i];
        if (k == "--root") a.root = v;
        else if (k == "--out") a.out = v;
        else if (k == "--preset") a.preset = v;
        else if (k == "--threads") a.threads = std::atoi(v.c_str());
        else {
            std::fprintf(stderr, "%s: unknown argument %s (--help)\n", argv[0], k.c_str());
            return 2;
        }
    }
    try {
        std::filesystem::create_directories(a.out);
        return a.root.empty() ? run_synthetic(a) : run_kitti(a);
    } catch (const lidarflow::Error &e) {
        // The library's status and message, e.g. "invalid argument: option 'threads' ...".
        std::fprintf(stderr, "lidarflow error (%s): %s\n", e.status_string(), e.what());
    } catch (const std::exception &e) {
        std::fprintf(stderr, "error: %s\n", e.what());
    }
    return 1;
}
