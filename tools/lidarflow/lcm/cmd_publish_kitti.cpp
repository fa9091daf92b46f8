// SPDX-License-Identifier: MIT
// lidarflow publish-kitti: plays a KITTI-layout folder onto LCM like a sensor rig would — the
// calibration, then per frame the LiDAR sweep and the stereo pair — so that
// lidarflow-lcm-bridge can be tried end to end with no other software. Built only with LCM
// (LIDARFLOW_WITH_LCM); the messages are the lidarflow LCM types (lcm_types/).
#include <lcm/lcm.h>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "log.hpp"
#include "eval/kitti_runner.hpp"
#include "io/calib.hpp"
#include "io/kitti_layout.hpp"
#include "io/velo_to_left.hpp"
#include "io/velodyne.hpp"
#include "bot_core_pointcloud_t.h"
#include "lidar/velodyne_protocol.hpp"
#include "lidarflow_calibration_t.h"
#include "lidarflow_lidar_t.h"
#include "lidarflow_stereo_t.h"

namespace lidarflow::cli {
namespace {

struct Channels {
    std::string stereo, lidar, calibration;
};

// How a sweep goes on the wire: what a projection of the scan gives (sparse disparities), or the
// raw sweep in the LiDAR frame as a Velodyne driver sends it (lidar_t with the transform, or
// bot_core.pointcloud_t without one).
enum class SweepWire { Disparity, LidarT, PointcloudT };

// One KITTI id, loaded once and replayed as often as asked.
struct Clip {
    std::string id;
    StereoCamera camera;
    eval::KittiFrame frame;
    // Raw sweeps (SweepWire::LidarT / PointcloudT): Velodyne frame, t0 and t1 (empty when the
    // folder has no scan at t1, as KITTI 2015), and Velodyne -> left rectified camera.
    std::vector<io::VelodynePoint> raw[2];
    cv::Matx44d lidar_to_camera = cv::Matx44d::eye();
};

// The transform lidar_t.lcm defines (Velodyne -> *left rectified* camera, camera 2's offset
// included), the one the C ABI's lf_read_kitti_calibration gives.
cv::Matx44d kitti_lidar_to_camera(const io::KittiLayout &layout, const std::string &id) {
    return io::velo_to_left_rect(io::read_calib_cam_to_cam(layout.calib_cam_to_cam(id)),
                                 io::read_calib_velo_to_cam(layout.calib_velo_to_cam(id)));
}

// Row-major, shortest text that reads back to the same doubles: the bridge's --lidar-to-camera.
std::string matrix_text(const cv::Matx44d &T) {
    std::string s;
    char buf[32];
    for (int i = 0; i < 16; ++i) {
        std::snprintf(buf, sizeof buf, "%s%.17g", i ? " " : "", T.val[i]);
        s += buf;
    }
    return s;
}

std::vector<io::VelodynePoint> read_raw_sweep(const std::string &path, int beams) {
    io::VelodyneScan scan = io::read_velodyne_bin(path);
    return beams > 0 ? lidar::keep_beams(scan.points, beams) : std::move(scan.points);
}

void publish_calibration(lcm_t *lcm, const Channels &ch, const StereoCamera &cam, int64_t utime, const cv::Size &size) {
    lidarflow_calibration_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.width = size.width;
    m.height = size.height;
    m.fx = cam.fx;
    m.fy = cam.fy;
    m.cx = cam.cx;
    m.cy = cam.cy;
    m.baseline = cam.baseline;
    require(lidarflow_calibration_t_publish(lcm, ch.calibration.c_str(), &m) == 0, ErrorCode::Io,
            "publish-kitti: publishing the calibration failed");
}

void publish_lidar(lcm_t *lcm, const Channels &ch, const SparseLidar &lidar, int64_t utime) {
    const size_t n = lidar.points.size();
    std::vector<float> x(n), y(n), z(n);
    for (size_t i = 0; i < n; ++i) {
        x[i] = static_cast<float>(lidar.points[i].x);
        y[i] = static_cast<float>(lidar.points[i].y);
        z[i] = lidar.points[i].disparity;
    }
    lidarflow_lidar_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.frame = LIDARFLOW_LIDAR_T_FRAME_DISPARITY;
    for (int i = 0; i < 4; ++i) m.lidar_to_camera[5 * i] = 1.0;  // unused for disparities
    m.num_points = static_cast<int32_t>(n);
    m.x = x.data();
    m.y = y.data();
    m.z = z.data();
    require(lidarflow_lidar_t_publish(lcm, ch.lidar.c_str(), &m) == 0, ErrorCode::Io,
            "publish-kitti: publishing a LiDAR sweep failed");
}

// The sweep as a driver publishes it: points in the LiDAR frame, as read from the scan.
void publish_raw_lidar(lcm_t *lcm, const Channels &ch, SweepWire wire, const std::vector<io::VelodynePoint> &points,
                       const cv::Matx44d &lidar_to_camera, int64_t utime, int32_t seq) {
    const size_t n = points.size();
    require(n <= 50000000, ErrorCode::InvalidArgument, "publish-kitti: a sweep of more than 5e7 points");
    int rc;
    if (wire == SweepWire::LidarT) {
        std::vector<float> x(n), y(n), z(n);
        for (size_t i = 0; i < n; ++i) {
            x[i] = points[i].x;
            y[i] = points[i].y;
            z[i] = points[i].z;
        }
        lidarflow_lidar_t m;
        std::memset(&m, 0, sizeof m);
        m.utime = utime;
        m.frame = LIDARFLOW_LIDAR_T_FRAME_LIDAR;
        std::memcpy(m.lidar_to_camera, lidar_to_camera.val, sizeof m.lidar_to_camera);
        m.num_points = static_cast<int32_t>(n);
        m.x = x.data();
        m.y = y.data();
        m.z = z.data();
        rc = lidarflow_lidar_t_publish(lcm, ch.lidar.c_str(), &m);
    } else {
        std::vector<float> xyz(3 * n);
        std::vector<float *> rows(n);
        for (size_t i = 0; i < n; ++i) {
            xyz[3 * i] = points[i].x;
            xyz[3 * i + 1] = points[i].y;
            xyz[3 * i + 2] = points[i].z;
            rows[i] = &xyz[3 * i];
        }
        char frame_id[] = "velodyne";
        bot_core_pointcloud_t m;
        std::memset(&m, 0, sizeof m);
        m.utime = utime;
        m.seq = seq;
        m.frame_id = frame_id;
        m.n_points = static_cast<int32_t>(n);
        m.points = rows.data();
        rc = bot_core_pointcloud_t_publish(lcm, ch.lidar.c_str(), &m);
    }
    require(rc == 0, ErrorCode::Io, "publish-kitti: publishing a LiDAR sweep failed");
}

void publish_stereo(lcm_t *lcm, const Channels &ch, const cv::Mat &left, const cv::Mat &right, int64_t utime,
                    int32_t sequence, int64_t frame_number) {
    require(left.isContinuous() && right.isContinuous() && left.type() == right.type() &&
                (left.type() == CV_8UC1 || left.type() == CV_8UC3),
            ErrorCode::Format, "publish-kitti: images must be 8-bit gray or colour");
    lidarflow_stereo_t m;
    std::memset(&m, 0, sizeof m);
    m.utime = utime;
    m.sequence = sequence;
    m.frame_number = frame_number;
    m.width = left.cols;
    m.height = left.rows;
    m.row_stride = static_cast<int32_t>(left.step[0]);
    m.pixel_format = left.channels() == 1 ? LIDARFLOW_STEREO_T_PIXEL_GRAY8 : LIDARFLOW_STEREO_T_PIXEL_BGR8;
    m.size = m.row_stride * m.height;
    m.left = left.data;
    m.right = right.data;
    require(lidarflow_stereo_t_publish(lcm, ch.stereo.c_str(), &m) == 0, ErrorCode::Io,
            "publish-kitti: publishing a stereo pair failed (message too large for the provider?)");
}

int run(int argc, char **argv) {
    Args args("publish-kitti", argc, argv,
              {{"root", true, "DIR  KITTI-layout folder (image_2/3, calib_cam_to_cam, LiDAR sources)"},
               {"ids", true, "A,B  frame ids (default: every frame in root)"},
               {"lidar", true, "P    LiDAR protocol: paper (default) | velodyne | none"},
               {"points", true, "N    LiDAR points per map (paper: default 88; velodyne: thin to N, 0 = all)"},
               {"beams", true, "K    velodyne: keep K beams (default 0 = all)"},
               {"lidar-frame", true, "F    disparity (default: the projected scan) | lidar (velodyne: the raw sweep)"},
               {"lidar-type", true, "T    lidar-frame lidar as: lidar_t (default, with the transform) | pointcloud_t"},
               {"print-lidar-to-camera", false, "print the bridge's --lidar-to-camera for the ids and exit"},
               {"lcm-url", true, "URL  LCM provider (default: $LCM_DEFAULT_URL or LCM's default)"},
               {"rate", true, "HZ   stereo frames per second (default 10; 0 = as fast as possible)"},
               {"loop", true, "N    play the ids N times (default 1)"},
               {"stereo-channel", true, "NAME (default LIDARFLOW_STEREO)"},
               {"lidar-channel", true, "NAME (default LIDARFLOW_LIDAR)"},
               {"calib-channel", true, "NAME (default LIDARFLOW_CALIB)"},
               {"start-delay", true, "S    wait S seconds after opening LCM (default 0)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        std::printf("Each id is one sequence of two frames (ID_10, ID_11), 1/rate apart; the sequence number\n"
                    "changes from id to id so that receivers never pair frames across a scene cut. Per frame\n"
                    "it publishes the LiDAR sweep (if the protocol gives one) before the stereo pair; the\n"
                    "calibration goes out at the start of every sequence.\n"
                    "--lidar velodyne --lidar-frame lidar sends velodyne/ID.bin (and ID_11.bin where present)\n"
                    "as a driver would: every point, in the Velodyne frame. As pointcloud_t the bridge needs\n"
                    "  --lidar-to-camera \"$(lidarflow publish-kitti --root DIR --ids ID --print-lidar-to-camera)\"\n");
        return 0;
    }
    const std::string root = args.required("root");
    const io::KittiLayout layout{root};
    std::vector<std::string> ids = args.list("ids");
    if (ids.empty()) ids = layout.frame_ids();
    require(!ids.empty(), ErrorCode::InvalidArgument, "publish-kitti: no frames in " + root);
    if (args.flag("print-lidar-to-camera")) {
        // One bridge takes one --lidar-to-camera: ids from different drives need their own runs.
        const cv::Matx44d T = kitti_lidar_to_camera(layout, ids[0]);
        for (const std::string &id : ids)
            require(kitti_lidar_to_camera(layout, id) == T, ErrorCode::InvalidArgument,
                    "publish-kitti: ids " + ids[0] + " and " + id +
                        " have different LiDAR -> camera transforms; print them one id at a time");
        std::printf("%s\n", matrix_text(T).c_str());
        return 0;
    }
    eval::LidarInputOptions lidar_opt;
    lidar_opt.protocol = eval::parse_protocol(args.str("lidar", "paper"));
    const bool velodyne = lidar_opt.protocol == eval::LidarProtocol::Velodyne;
    lidar_opt.points = args.integer("points", velodyne ? 0 : 88);
    lidar_opt.beams = args.integer("beams", 0);
    const std::string frame_name = args.str("lidar-frame", "disparity"), type_name = args.str("lidar-type", "lidar_t");
    require(frame_name == "disparity" || frame_name == "lidar", ErrorCode::InvalidArgument,
            "publish-kitti: --lidar-frame " + frame_name + ": expected disparity or lidar");
    require(type_name == "lidar_t" || type_name == "pointcloud_t", ErrorCode::InvalidArgument,
            "publish-kitti: --lidar-type " + type_name + ": expected lidar_t or pointcloud_t");
    const SweepWire wire = frame_name == "disparity" ? SweepWire::Disparity
                           : type_name == "lidar_t"  ? SweepWire::LidarT
                                                     : SweepWire::PointcloudT;
    require(wire != SweepWire::Disparity || type_name == "lidar_t", ErrorCode::InvalidArgument,
            "publish-kitti: --lidar-type pointcloud_t carries points, not disparities: add --lidar-frame lidar");
    if (wire != SweepWire::Disparity) {
        require(velodyne, ErrorCode::InvalidArgument,
                "publish-kitti: --lidar-frame lidar sends the raw Velodyne scans: it needs --lidar velodyne");
        // A driver sends the whole sweep; thinning to N points is a property of the projection.
        require(lidar_opt.points == 0, ErrorCode::InvalidArgument,
                "publish-kitti: --points thins the projected scan; with --lidar-frame lidar the whole sweep goes "
                "out (--beams K thins it by lasers)");
        require(lidar_opt.beams >= 0, ErrorCode::InvalidArgument, "publish-kitti: --beams must be >= 0");
    }
    const double rate = args.number("rate", 10.0);
    require(rate >= 0 && rate <= 1000, ErrorCode::InvalidArgument, "publish-kitti: --rate must be in [0, 1000]");
    const int loops = args.integer("loop", 1);
    require(loops >= 1, ErrorCode::InvalidArgument, "publish-kitti: --loop must be >= 1");
    const double start_delay = args.number("start-delay", 0.0);
    require(start_delay >= 0 && start_delay <= 60, ErrorCode::InvalidArgument,
            "publish-kitti: --start-delay must be in [0, 60]");
    const Channels ch{args.str("stereo-channel", "LIDARFLOW_STEREO"), args.str("lidar-channel", "LIDARFLOW_LIDAR"),
                      args.str("calib-channel", "LIDARFLOW_CALIB")};
    inputs_begin();

    // Loading and publishing can take minutes (--rate, --loop): lines with elapsed time and ETA,
    // piped at most one every 2 s besides the first and the last.
    Progress load_bar(verbosity() != Verbosity::Quiet, isatty(fileno(stderr)) != 0, 2.0);
    std::vector<Clip> clips;
    for (const std::string &id : ids) {
        load_bar.update(static_cast<double>(clips.size()), static_cast<double>(ids.size()),
                        "publish-kitti: loading [" + std::to_string(clips.size() + 1) + "/" + std::to_string(ids.size()) +
                            "] " + id);
        Clip c;
        c.id = id;
        c.camera = io::read_calib_cam_to_cam(layout.calib_cam_to_cam(id)).camera;
        eval::LidarInputOptions images_only = lidar_opt;
        if (wire != SweepWire::Disparity) images_only.protocol = eval::LidarProtocol::None;
        c.frame = eval::load_kitti_frame(root, id, images_only);
        if (wire != SweepWire::Disparity) {
            c.lidar_to_camera = kitti_lidar_to_camera(layout, id);
            // As the velodyne protocol: the scan at t1 only where the folder has one.
            c.raw[0] = read_raw_sweep(layout.velodyne(id), lidar_opt.beams);
            if (std::filesystem::exists(layout.velodyne_t1(id)))
                c.raw[1] = read_raw_sweep(layout.velodyne_t1(id), lidar_opt.beams);
        }
        if (wire == SweepWire::PointcloudT && !clips.empty())
            require(c.lidar_to_camera == clips[0].lidar_to_camera, ErrorCode::InvalidArgument,
                    "publish-kitti: ids " + clips[0].id + " and " + id +
                        " have different LiDAR -> camera transforms, and a pointcloud_t carries none (the bridge "
                        "takes one --lidar-to-camera): publish them separately, or use --lidar-type lidar_t");
        clips.push_back(std::move(c));
    }
    load_bar.finish();

    const std::string url = args.str("lcm-url", "");
    lcm_t *lcm = lcm_create(url.empty() ? nullptr : url.c_str());
    require(lcm != nullptr, ErrorCode::Io, "publish-kitti: cannot open LCM '" + url + "'");
    struct LcmCloser {
        lcm_t *l;
        ~LcmCloser() { lcm_destroy(l); }
    } closer{lcm};
    if (start_delay > 0) std::this_thread::sleep_for(std::chrono::duration<double>(start_delay));

    // Sensor time: wall clock at the start, then exactly one period per stereo frame.
    const int64_t period_us = static_cast<int64_t>(1e6 / (rate > 0 ? rate : 10.0));
    const int64_t t_start =
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count();
    const auto wall_start = std::chrono::steady_clock::now();
    int64_t frames = 0, sweeps = 0;
    int32_t sequence = 0;
    const int64_t total = static_cast<int64_t>(clips.size()) * 2 * loops;
    Progress bar(verbosity() != Verbosity::Quiet, isatty(fileno(stderr)) != 0, 2.0);
    for (int loop = 0; loop < loops; ++loop)
        for (const Clip &c : clips) {
            const pipeline::FrameInput &in = c.frame.input;
            for (int t = 0; t < 2; ++t) {
                const int64_t utime = t_start + frames * period_us;
                if (rate > 0) std::this_thread::sleep_until(wall_start + std::chrono::microseconds(frames * period_us));
                if (t == 0) publish_calibration(lcm, ch, c.camera, utime, in.left0.size());
                const SparseLidar &lidar = t == 0 ? in.lidar0 : in.lidar1;
                if (wire != SweepWire::Disparity) {
                    if (!c.raw[t].empty()) {
                        publish_raw_lidar(lcm, ch, wire, c.raw[t], c.lidar_to_camera, utime,
                                          static_cast<int32_t>(sweeps));
                        ++sweeps;
                    }
                } else if (lidar_opt.protocol != eval::LidarProtocol::None && !lidar.points.empty()) {
                    publish_lidar(lcm, ch, lidar, utime);
                    ++sweeps;
                }
                publish_stereo(lcm, ch, t == 0 ? in.left0 : in.left1, t == 0 ? in.right0 : in.right1, utime, sequence,
                               frames);
                ++frames;
                bar.update(static_cast<double>(frames), static_cast<double>(total),
                           "publish-kitti: [" + std::to_string(frames) + "/" + std::to_string(total) + "] " + c.id +
                               (t == 0 ? "_10" : "_11") + (loops > 1 ? ", loop " + std::to_string(loop + 1) : ""));
            }
            ++sequence;
        }
    bar.finish();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    std::printf("published %lld stereo frames, %lld LiDAR sweeps, %d calibrations (%zu ids x %d loops) in %.2f s\n",
                static_cast<long long>(frames), static_cast<long long>(sweeps), sequence, clips.size(), loops, seconds);
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(publish_kitti, "publish-kitti", "play a KITTI-layout folder onto LCM (for lidarflow-lcm-bridge)", run,
                  90);

}  // namespace lidarflow::cli
