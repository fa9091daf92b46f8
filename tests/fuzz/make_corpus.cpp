// SPDX-License-Identifier: MIT
// Writes the seed corpora of the fuzz targets (tests/fuzz/corpus/<target>/) with the project's
// own encoders and writers, so that the seeds are what the code under test really receives:
//     build-fuzz/tests/fuzz/lidarflow_fuzz_corpus tests/fuzz/corpus
// Each seed is small (the fuzzers mutate from it) and valid; the fuzzers find the invalid ones.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "capi_program.hpp"
#include "core/error.hpp"
#include "core/maps.hpp"
#include "io/calib.hpp"
#include "io/kitti_png.hpp"
#include "io/point_cloud.hpp"
#include "io/rig.hpp"
#include "io/result_formats.hpp"
#include "io/velodyne.hpp"
#include "log_reader.hpp"
#include "wire.hpp"

namespace {

namespace fs = std::filesystem;
using namespace lidarflow;
using namespace lidarflow::fuzz;

fs::path g_root;

void save(const std::string &target, const std::string &name, const std::vector<uint8_t> &bytes) {
    fs::create_directories(g_root / target);
    std::ofstream out(g_root / target / name, std::ios::binary);
    out.write(reinterpret_cast<const char *>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    require(out.good(), ErrorCode::Io, "cannot write " + (g_root / target / name).string());
}

std::vector<uint8_t> file_bytes(const fs::path &path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<uint8_t> text_bytes(const std::string &s) { return {s.begin(), s.end()}; }

template <class M, class Size, class Encode>
std::vector<uint8_t> encode(M &m, Size size_of, Encode encode_fn) {
    std::vector<uint8_t> b(static_cast<size_t>(size_of(&m)));
    require(encode_fn(b.data(), 0, static_cast<int>(b.size()), &m) == static_cast<int>(b.size()), ErrorCode::Internal,
            "lcm-gen encoder failed");
    return b;
}

void lcm_seeds() {
    // stereo_t: gray without padding, RGB with a padded stride, the smallest BGR.
    struct StereoSeed {
        const char *name;
        int32_t w, h, stride;
        int8_t format;
    } stereo[] = {{"gray_4x3", 4, 3, 4, LIDARFLOW_STEREO_T_PIXEL_GRAY8},
                  {"rgb_5x2_padded", 5, 2, 17, LIDARFLOW_STEREO_T_PIXEL_RGB8},
                  {"bgr_1x1", 1, 1, 3, LIDARFLOW_STEREO_T_PIXEL_BGR8}};
    for (const StereoSeed &s : stereo) {
        std::vector<uint8_t> left(static_cast<size_t>(s.stride) * s.h), right(left.size());
        for (size_t i = 0; i < left.size(); ++i) {
            left[i] = static_cast<uint8_t>(i * 37);
            right[i] = static_cast<uint8_t>(i * 53);
        }
        lidarflow_stereo_t m{};
        m.utime = 1000;
        m.sequence = 2;
        m.frame_number = 41;
        m.width = s.w;
        m.height = s.h;
        m.row_stride = s.stride;
        m.pixel_format = s.format;
        m.size = s.stride * s.h;
        m.left = left.data();
        m.right = right.data();
        save("fuzz_lcm_stereo", s.name, encode(m, lidarflow_stereo_t_encoded_size, lidarflow_stereo_t_encode));
    }

    // lidar_t: one sweep per frame.
    std::vector<float> x = {1.0f, -2.0f, 0.5f}, y = {0.2f, 0.1f, -0.3f}, z = {5.0f, 12.0f, 30.0f};
    const int8_t frames[] = {LIDARFLOW_LIDAR_T_FRAME_CAMERA, LIDARFLOW_LIDAR_T_FRAME_LIDAR,
                             LIDARFLOW_LIDAR_T_FRAME_DISPARITY};
    const char *frame_names[] = {"camera_3", "lidar_3", "disparity_3"};
    for (int f = 0; f < 3; ++f) {
        lidarflow_lidar_t m{};
        m.utime = 2000;
        m.frame = frames[f];
        const double T[16] = {0, -1, 0, 0, 0, 0, -1, 0, 1, 0, 0, -0.27, 0, 0, 0, 1};
        for (int i = 0; i < 16; ++i) m.lidar_to_camera[i] = f == 1 ? T[i] : (i % 5 == 0 ? 1.0 : 0.0);
        m.num_points = 3;
        m.x = x.data();
        m.y = y.data();
        m.z = z.data();
        save("fuzz_lcm_lidar", frame_names[f], encode(m, lidarflow_lidar_t_encoded_size, lidarflow_lidar_t_encode));
    }

    // bot_core.images_t: a padded gray pair with a metadata entry on the left image; a
    // bot_core.pointcloud_t of 3 points with an intensity channel (lcm-gen's encoder).
    {
        uint8_t pixels[2][3 * 6];
        for (int k = 0; k < 2; ++k)
            for (int i = 0; i < 18; ++i) pixels[k][i] = static_cast<uint8_t>(11 * i + 50 * k);
        char key[] = "gain";
        uint8_t value[] = {4};
        bot_core_image_metadata_t meta{key, 1, value};
        bot_core_image_t ims[2]{};
        for (int k = 0; k < 2; ++k) {
            ims[k].utime = 1000;
            ims[k].width = 4;
            ims[k].height = 3;
            ims[k].row_stride = 6;
            ims[k].pixelformat = BOT_CORE_IMAGE_T_PIXEL_FORMAT_GRAY;
            ims[k].size = 18;
            ims[k].data = pixels[k];
            ims[k].nmetadata = k == 0 ? 1 : 0;
            ims[k].metadata = &meta;
        }
        int16_t roles[2] = {BOT_CORE_IMAGES_T_LEFT, BOT_CORE_IMAGES_T_RIGHT};
        bot_core_images_t m{1000, 2, roles, ims};
        save("fuzz_lcm_bot_images", "gray_4x3_padded", encode(m, bot_core_images_t_encoded_size, bot_core_images_t_encode));
        // The left one alone: a camera per channel (--left-channel).
        save("fuzz_lcm_bot_image", "gray_4x3_padded_metadata",
             encode(ims[0], bot_core_image_t_encoded_size, bot_core_image_t_encode));
        float p[3][3] = {{10, 1, -1}, {20, -2, 0.5f}, {5, 0, 0}};
        float *rows[3] = {p[0], p[1], p[2]};
        float intensity[3] = {0.1f, 0.2f, 0.3f};
        float *channels[1] = {intensity};
        char frame[] = "velodyne", name[] = "intensity";
        char *names[1] = {name};
        bot_core_pointcloud_t c{2000, 1, frame, 3, rows, 1, names, channels};
        save("fuzz_lcm_bot_pointcloud", "three_points",
             encode(c, bot_core_pointcloud_t_encoded_size, bot_core_pointcloud_t_encode));
    }

    // calibration_t: KITTI-like, for a fixed size and for any size.
    lf_calibration_t cal;
    lf_calibration_init(&cal);
    cal.fx = cal.fy = 721.5377;
    cal.cx = 609.5593;
    cal.cy = 172.854;
    cal.baseline = 0.5372;
    lidarflow_calibration_t c = bridge::calibration_message(cal, 3000, 1242, 375);
    save("fuzz_lcm_calibration", "kitti_1242x375",
         encode(c, lidarflow_calibration_t_encoded_size, lidarflow_calibration_t_encode));
    c = bridge::calibration_message(cal, 3000, 0, 0);
    save("fuzz_lcm_calibration", "any_size", encode(c, lidarflow_calibration_t_encoded_size, lidarflow_calibration_t_encode));

    // An LCM log as --replay reads it (bridge/log_reader): a calibration and a small stereo
    // frame, then the same with a torn tail.
    {
        lidarflow_stereo_t m{};
        uint8_t px[6] = {1, 2, 3, 4, 5, 6};
        m.utime = 5000;
        m.frame_number = 1;
        m.width = 3;
        m.height = 2;
        m.row_stride = 3;
        m.pixel_format = LIDARFLOW_STEREO_T_PIXEL_GRAY8;
        m.size = 6;
        m.left = m.right = px;
        const std::vector<uint8_t> stereo = encode(m, lidarflow_stereo_t_encoded_size, lidarflow_stereo_t_encode);
        const std::vector<uint8_t> calib = encode(c, lidarflow_calibration_t_encoded_size, lidarflow_calibration_t_encode);
        const fs::path tmp = fs::temp_directory_path() / "lidarflow_make_corpus.log";
        bridge::EventLogWriter w;
        require(w.open(tmp.string()) && w.write(3000, "LIDARFLOW_CALIB", calib.data(), calib.size()) &&
                    w.write(5000, "LIDARFLOW_STEREO", stereo.data(), stereo.size()) && w.close(),
                ErrorCode::Io, "cannot write " + tmp.string());
        std::vector<uint8_t> log = file_bytes(tmp);
        fs::remove(tmp);
        save("fuzz_lcm_eventlog", "calibration_and_stereo", log);
        log.resize(log.size() - 5);
        save("fuzz_lcm_eventlog", "torn_tail", log);
    }

    // scene_flow_t: what the bridge publishes (encode_flow + encode_scene_flow) for a 5x3 result.
    const uint32_t W = 5, H = 3;
    std::vector<float> planes[4];
    std::vector<uint8_t> valid(W * H);
    for (int k = 0; k < 4; ++k) {
        planes[k].resize(W * H);
        for (uint32_t i = 0; i < W * H; ++i) planes[k][i] = (i % 4 == 0) ? 0.0f : 0.75f * (k + 1) * (i % 5);
    }
    for (uint32_t i = 0; i < W * H; ++i) valid[i] = i % 4 != 0;
    lf_result_views_t views;
    lf_result_views_init(&views);
    views.width = W;
    views.height = H;
    lf_view_t *v[4] = {&views.u, &views.v, &views.d0, &views.d1};
    for (int k = 0; k < 4; ++k) *v[k] = {planes[k].data(), 4 * W};
    views.valid = {valid.data(), W};
    views.confidence = {planes[0].data(), 4 * W};
    const struct {
        const char *name;
        bridge::FlowEncoding encoding;
        int step;
    } flows[] = {{"float32_step1", bridge::FlowEncoding::Float32, 1}, {"int16_step2", bridge::FlowEncoding::Int16, 2}};
    for (const auto &f : flows) {
        bridge::FlowMessage msg;
        msg.header.utime = 200000;
        msg.header.utime0 = 100000;
        msg.header.last_stage = 4;
        std::string error;
        require(bridge::encode_flow(views, f.encoding, f.step, msg, &error), ErrorCode::Internal, error);
        lidarflow_scene_flow_t m = msg.message();
        save("fuzz_lcm_scene_flow", f.name, bridge::encode_scene_flow(m));
    }

    // ego_motion_t: what the bridge publishes (ego_motion_message + encode_ego_motion): a fitted
    // motion (5 deg about y, 0.8 m forward) and a result without one.
    {
        lf_ego_motion_t e;
        lf_ego_motion_init(&e);
        const double c = std::cos(5 * M_PI / 180), s = std::sin(5 * M_PI / 180);
        const double T[16] = {c, 0, s, 0.02, 0, 1, 0, -0.01, -s, 0, c, -0.8, 0, 0, 0, 1};
        std::copy(T, T + 16, e.transform);
        e.inliers = 900;
        e.candidates = 1000;
        lidarflow_ego_motion_t m = bridge::ego_motion_message(e, 200000, 100000, 3);
        save("fuzz_lcm_ego_motion", "fitted", bridge::encode_ego_motion(m));
        lf_ego_motion_init(&e);
        e.state = LF_EGO_TOO_FEW_INLIERS;
        for (int k = 0; k < 4; ++k) e.transform[5 * k] = 1;
        e.inliers = 20;
        e.candidates = 400;
        m = bridge::ego_motion_message(e, 300000, 200000, 3);
        save("fuzz_lcm_ego_motion", "too_few_inliers", bridge::encode_ego_motion(m));
    }

    // status_t: with and without a last error.
    const char *errors[] = {"", "stereo: truncated: 12 bytes"};
    for (int i = 0; i < 2; ++i) {
        lidarflow_status_t s{};
        s.utime = 4000;
        s.uptime_seconds = 1.5;
        s.stereo_received = 3;
        s.stereo_lost_in_transport = 1;
        s.stereo_processed = 2;
        s.dropped_malformed = 1;
        s.dropped_unpaired = i;
        s.queue_capacity = 2;
        s.shard_index = i;
        s.shard_count = 2;
        s.skipped_other_shard = i;
        s.shards_dead = i;
        s.pairs_lost_dead_shard = 3 * i;
        s.latency_mean_ms = 12.5f;
        s.last_error = const_cast<char *>(errors[i]);
        save("fuzz_lcm_status", i == 0 ? "no_error" : "with_error",
             encode(s, lidarflow_status_t_encoded_size, lidarflow_status_t_encode));
    }
}

// The PLY point cloud `lidarflow run --ply` writes and `viz --points` reads: two points.
void ply_seeds() {
    const fs::path tmp = fs::temp_directory_path() / "lidarflow_make_corpus.ply";
    std::vector<io::CloudPoint> points = {
        {cv::Vec3f(1, 2, 10), cv::Vec3f(0.1f, 0, -0.5f), cv::Vec3b(200, 0, 30), false, cv::Vec3f()},
        {cv::Vec3f(-3, 0.5f, 25), cv::Vec3f(0, 0, 0), cv::Vec3b(0, 255, 7), false, cv::Vec3f()}};
    io::write_ply(tmp.string(), points);
    save("fuzz_io_ply", "two_points", file_bytes(tmp));
    // With object motion (omx omy omz), as `run --points` writes when the ego-motion is known.
    points[0].has_object_motion = points[1].has_object_motion = true;
    points[0].object_motion = cv::Vec3f(0.1f, 0, 0.3f);
    points[1].object_motion = cv::Vec3f(0, 0, 0.8f);
    io::write_ply(tmp.string(), points);
    save("fuzz_io_ply", "two_points_object_motion", file_bytes(tmp));
    fs::remove(tmp);
}

// The float result files `lidarflow run --format pfm|npy|flo` writes and `viz` reads, 3x2 px,
// each behind the byte that makes fuzz_io_result_files pick its reader (0 pfm, 1 npy, 2 flo).
void result_file_seeds() {
    const fs::path tmp = fs::temp_directory_path() / "lidarflow_make_corpus.result";
    auto seed = [&](uint8_t reader, const std::string &name) {
        std::vector<uint8_t> b = file_bytes(tmp);
        b.insert(b.begin(), reader);
        save("fuzz_io_result_files", name, b);
    };
    cv::Mat1f disp(2, 3);
    cv::Mat3f flow(2, 3);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) {
            disp(y, x) = x == 1 && y == 0 ? std::nanf("") : 10.5f + x - y;
            flow(y, x) = cv::Vec3f(1.25f * x, -0.5f * y, 1);
        }
    io::write_pfm(tmp.string(), disp);
    seed(0, "disparity_pfm");
    io::write_pfm(tmp.string(), flow);
    seed(0, "flow_pfm");
    io::write_npy(tmp.string(), disp);
    seed(1, "disparity_npy");
    io::write_npy(tmp.string(), flow);
    seed(1, "flow_npy");
    FlowField f = FlowField::zeros(3, 2);
    f.u(0, 0) = 2.5f;
    f.valid(0, 0) = 1;
    f.v(1, 2) = -1;
    f.valid(1, 2) = 1;
    io::write_flo(tmp.string(), f);
    seed(2, "flow_flo");
    fs::remove(tmp);
}

void kitti_seeds() {
    const fs::path tmp = g_root / ".tmp";
    fs::create_directories(tmp);
    DisparityMap d(3, 4, kInvalidDisparity);
    d(0, 1) = 12.5f;
    d(2, 3) = 0.0f;
    d(1, 2) = 200.25f;
    io::write_disparity_png((tmp / "d.png").string(), d);
    save("fuzz_kitti_png", "disparity_4x3.png", file_bytes(tmp / "d.png"));
    FlowField f = FlowField::zeros(4, 3);
    f.u(1, 1) = -3.5f;
    f.v(1, 1) = 2.25f;
    f.valid(1, 1) = 1;
    f.valid(2, 0) = 1;
    io::write_flow_png((tmp / "f.png").string(), f);
    save("fuzz_kitti_png", "flow_4x3.png", file_bytes(tmp / "f.png"));
    cv::Mat gray(4, 5, CV_8UC1), bgr(2, 3, CV_8UC3);
    cv::randu(gray, 0, 255);
    cv::randu(bgr, 0, 255);
    io::write_image((tmp / "g.png").string(), gray);
    save("fuzz_kitti_png", "gray_5x4.png", file_bytes(tmp / "g.png"));
    io::write_image((tmp / "c.png").string(), bgr);
    save("fuzz_kitti_png", "bgr_3x2.png", file_bytes(tmp / "c.png"));
    // Formats OpenCV decodes but the readers must refuse (PNG signature check): the fuzzer
    // starts next to them.
    for (const char *ext : {".bmp", ".tiff", ".pgm"}) {
        std::vector<uint8_t> other;
        require(cv::imencode(ext, gray, other), ErrorCode::Internal, std::string("cv::imencode ") + ext);
        save("fuzz_kitti_png", std::string("not_png_gray_5x4") + ext, other);
    }

    StereoCamera cam;
    cam.fx = cam.fy = 721.5377;
    cam.cx = 609.5593;
    cam.cy = 172.854;
    cam.baseline = 0.5372;
    io::write_calib_cam_to_cam((tmp / "cam.txt").string(), io::calib_from_camera(cam));
    const std::vector<uint8_t> cam_text = file_bytes(tmp / "cam.txt");
    save("fuzz_kitti_calib", "cam_to_cam.txt", cam_text);
    // No writer exists for calib_velo_to_cam: KITTI's own layout, with the keys it carries.
    const std::string velo =
        "calib_time: 15-Mar-2012 11:37:16\n"
        "R: 7.533745e-03 -9.999714e-01 -6.166020e-04 1.480249e-02 7.280733e-04 -9.998902e-01 "
        "9.998621e-01 7.523790e-03 1.480755e-02\n"
        "T: -4.069766e-03 -7.631618e-02 -2.717806e-01\n"
        "delta_f: 0.000000e+00 0.000000e+00\n";
    save("fuzz_kitti_calib", "velo_to_cam.txt", text_bytes(velo));
    std::vector<uint8_t> both = cam_text;
    const std::vector<uint8_t> velo_bytes = text_bytes(velo);
    both.insert(both.end(), velo_bytes.begin(), velo_bytes.end());
    save("fuzz_kitti_calib", "both.txt", both);

    // Calibration files of other rigs (io/rig.hpp): OpenCV's own writer, YAML and XML, an
    // identity rig and a raw one; a camera_info pair as the fuzz target splits it.
    const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
    for (const char *ext : {".yml", ".xml"}) {
        for (const bool raw : {false, true}) {
            cv::FileStorage fs(std::string(ext) + "", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
            fs << "image_width" << 1242 << "image_height" << 375 << "M1" << cv::Mat(K) << "D1"
               << cv::Mat(cv::Matx<double, 1, 5>(raw ? -0.3 : 0, raw ? 0.1 : 0, 0, 0, 0)) << "M2" << cv::Mat(K) << "D2"
               << cv::Mat::zeros(1, 5, CV_64F) << "R" << cv::Mat::eye(3, 3, CV_64F) << "T"
               << cv::Mat(cv::Matx31d(-cam.baseline, 0, 0));
            save("fuzz_io_calibration", std::string(raw ? "raw_stereo" : "stereo") + ext,
                 text_bytes(fs.releaseAndGetString()));
        }
    }
    auto camera_info = [&](double tx, const char *d) {
        char p[160];
        std::snprintf(p, sizeof p, "[%.17g, 0, %.17g, %.17g, 0, %.17g, %.17g, 0, 0, 0, 1, 0]", cam.fx, cam.cx, tx,
                      cam.fy, cam.cy);
        char k[160];
        std::snprintf(k, sizeof k, "[%.17g, 0, %.17g, 0, %.17g, %.17g, 0, 0, 1]", cam.fx, cam.cx, cam.fy, cam.cy);
        return std::string("image_width: 1242\nimage_height: 375\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: ") + k +
               "\ndistortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: " + d +
               "\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
               "projection_matrix:\n  rows: 3\n  cols: 4\n  data: " + p + "\n";
    };
    save("fuzz_io_calibration", "camera_info_pair.yaml",
         text_bytes(camera_info(0, "[0, 0, 0, 0, 0]") + "%%\n" + camera_info(-cam.fx * cam.baseline, "[0, 0, 0, 0, 0]")));
    save("fuzz_io_calibration", "camera_info_raw_pair.yaml",
         text_bytes(camera_info(0, "[-0.3, 0.1, 0, 0, 0]") + "%%\n" + camera_info(-cam.fx * cam.baseline, "[0, 0, 0, 0, 0]")));

    // Velodyne: three records (x, y, z, reflectance), the second with a NaN (dropped).
    const float records[12] = {10.5f, -1.25f, -1.7f, 0.3f, NAN, 0.0f, 0.0f, 0.0f, 4.0f, 2.0f, 0.5f, 0.9f};
    std::vector<uint8_t> bin(sizeof records);
    std::memcpy(bin.data(), records, sizeof records);
    save("fuzz_kitti_velodyne", "three_records.bin", bin);
    fs::remove_all(tmp);
}

// Programs of fuzz_capi (capi_program.hpp).
struct ProgramWriter {
    std::vector<uint8_t> b;
    ProgramWriter &u8(int v) {
        b.push_back(static_cast<uint8_t>(v));
        return *this;
    }
    template <class T, size_t N>
    static int index_of(const T (&table)[N], const char *s) {
        for (size_t i = 0; i < N; ++i)
            if (std::strcmp(table[i], s) == 0) return static_cast<int>(i);
        throw Error(ErrorCode::Internal, std::string("not in the table: ") + s);
    }
    ProgramWriter &set_string(const char *key, const char *value) {
        return u8(2).u8(index_of(kKeys, key)).u8(index_of(kStrings, value));
    }
    ProgramWriter &set_int(const char *key, int table_index) { return u8(0).u8(index_of(kKeys, key)).u8(table_index); }
    ProgramWriter &calibration(int mode, int fx_byte, int baseline_byte, int create_flags) {
        return u8(mode).u8(fx_byte).u8(baseline_byte).u8(create_flags);
    }
    // A push of a w x h frame; LiDAR consistent with the scene (values mode 0).
    ProgramWriter &push(int w, int h, int format, int motion, int disparity, int lidar_kind, int count,
                        int stride_mode = 0, int lidar_stride_sel = 0) {
        u8(kPush).u8(w - 1).u8(h - 1).u8(format).u8(stride_mode).u8(3).u8(0).u8(motion).u8(disparity).u8(42).u8(100);
        return u8(lidar_kind).u8(count).u8(lidar_stride_sel).u8(0);
    }
    ProgramWriter &all_results() {
        u8(kHasResult).u8(kInfo).u8(0).u8(kTiming).u8(0).u8(0).u8(kViews);
        u8(kResult).u8(0x3F).u8(1).u8(0);
        return u8(kPoints).u8(7).u8(1).u8(0);
    }
};

void capi_seeds() {
    // With fuzz_capi's search ranges (flow 16 px, disparity 32 px) frames from 16x12 up reach
    // full dense results; the larger ones take longer (64x48: ~4x the time of 32x24).
    ProgramWriter a;  // two gray frames with LiDAR disparities, every result call
    a.u8(0).calibration(0, 60, 64, 0).push(16, 12, LF_PIXEL_GRAY8, 2, 5, 4, 12).push(16, 12, LF_PIXEL_GRAY8, 2, 5, 4, 12);
    a.all_results();
    save("fuzz_capi", "gray_16x12_disparity_lidar", a.b);

    ProgramWriter b;  // RGB with points in the LiDAR frame (calibration with a transform), padded rows
    b.u8(0).calibration(1, 100, 32, 0).push(24, 16, LF_PIXEL_RGB8, -3, 6, 3, 20, 1, 2);
    b.push(24, 16, LF_PIXEL_RGB8, -3, 6, 3, 20, 1, 2).all_results();
    save("fuzz_capi", "rgb_24x16_lidar_points", b.b);

    ProgramWriter c;  // options: stop after matching, image-only; BGR, no LiDAR
    c.u8(2).set_string("last_stage", "matching").set_int("use_lidar", 0).calibration(2, 40, 100, 0);
    c.push(16, 12, LF_PIXEL_BGR8, 1, 3, 0, 0).push(16, 12, LF_PIXEL_BGR8, 1, 3, 0, 0).all_results();
    save("fuzz_capi", "bgr_16x12_matching_only", c.b);

    ProgramWriter d;  // out of order: results first, reset between frames, a new size, recreate
    d.u8(1).set_string("preset", "default").calibration(4, 60, 50, 1).all_results();
    d.push(16, 12, LF_PIXEL_GRAY8, 1, 4, 2, 8).u8(kReset).all_results();
    d.push(20, 14, LF_PIXEL_GRAY8, 1, 4, 2, 8).push(20, 14, LF_PIXEL_GRAY8, 1, 4, 2, 8).all_results();
    d.u8(kRecreate).push(20, 14, LF_PIXEL_GRAY8, 1, 4, 2, 8).u8(kErrors).u8(3);
    save("fuzz_capi", "out_of_order", d.b);

    ProgramWriter f;  // a mid-size pair: RGB, LiDAR disparities, every result call
    f.u8(0).calibration(0, 90, 80, 0).push(32, 24, LF_PIXEL_RGB8, 1, 4, 4, 24).push(32, 24, LF_PIXEL_RGB8, 1, 4, 4, 24);
    f.all_results();
    save("fuzz_capi", "rgb_32x24_disparity_lidar", f.b);

    ProgramWriter g;  // three frames: two results in a row, the second from the cached t1 features
    g.u8(0).calibration(3, 70, 90, 0).push(48, 36, LF_PIXEL_GRAY8, -2, 6, 3, 31);
    g.push(48, 36, LF_PIXEL_GRAY8, -2, 6, 3, 31).all_results().push(48, 36, LF_PIXEL_GRAY8, -2, 6, 3, 31).all_results();
    save("fuzz_capi", "gray_48x36_three_frames", g.b);

    ProgramWriter e;  // the largest frames, camera-frame points
    e.u8(0).calibration(6, 80, 60, 0).push(64, 48, LF_PIXEL_GRAY8, 2, 7, 2, 30).push(64, 48, LF_PIXEL_GRAY8, 2, 7, 2, 30);
    e.all_results();
    save("fuzz_capi", "gray_64x48_camera_points", e.b);
}

// --check: every seed of the decoder and reader targets, through the code under test, as the
// fuzz target sees it. A seed is meant to be accepted by at least one reader of its target,
// except the not_png_* ones, which every reader must refuse. Prints one line per seed and
// reader; returns the number of seeds that do not behave as meant. (fuzz_capi seeds: run the
// target with FUZZ_CAPI_TRACE=1 / FUZZ_CAPI_STATS=1.)
template <class F>
std::string outcome(F f) {
    try {
        return f();
    } catch (const std::exception &e) {
        return std::string("rejected: ") + e.what();
    }
}

int check_seeds() {
    int bad = 0;
    const char *targets[] = {"fuzz_lcm_stereo",     "fuzz_lcm_lidar",   "fuzz_lcm_calibration", "fuzz_lcm_scene_flow",
                             "fuzz_lcm_ego_motion",
                             "fuzz_lcm_status",     "fuzz_lcm_bot_image", "fuzz_kitti_png",     "fuzz_kitti_calib",
                             "fuzz_kitti_velodyne", "fuzz_io_calibration"};
    for (const char *t : targets) {
        const std::string target = t;
        std::vector<fs::path> seeds;
        for (const auto &e : fs::directory_iterator(g_root / target)) seeds.push_back(e.path());
        std::sort(seeds.begin(), seeds.end());
        if (seeds.empty()) {
            std::printf("%s: no seeds\n", t);
            ++bad;
        }
        for (const fs::path &seed : seeds) {
            const std::vector<uint8_t> b = file_bytes(seed);
            const std::string text(b.begin(), b.end());
            // reader name -> "ok ..." or "rejected: ..."
            std::vector<std::pair<std::string, std::string>> r;
            auto lcm = [](const std::string &err, const std::string &ok) { return err.empty() ? ok : "rejected: " + err; };
            if (target == "fuzz_lcm_stereo") {
                bridge::StereoMessage m;
                const std::string err = bridge::decode_stereo(b.data(), b.size(), m);
                r.emplace_back("decode_stereo", lcm(err, err.empty() ? "ok " + std::to_string(m.left().width) + "x" +
                                                                           std::to_string(m.left().height) +
                                                                           " frame " + std::to_string(m.msg().frame_number)
                                                                     : ""));
            } else if (target == "fuzz_lcm_lidar") {
                bridge::LidarSweep sw;
                const std::string err = bridge::decode_lidar(b.data(), b.size(), sw);
                r.emplace_back("decode_lidar", lcm(err, "ok"));
            } else if (target == "fuzz_lcm_calibration") {
                lf_calibration_t c;
                int32_t w = 0, h = 0;
                const std::string err = bridge::decode_calibration(b.data(), b.size(), &c, &w, &h);
                r.emplace_back("decode_calibration", lcm(err, "ok fx " + std::to_string(c.fx)));
            } else if (target == "fuzz_lcm_scene_flow") {
                bridge::DecodedFlow f;
                const std::string err = bridge::decode_scene_flow(b.data(), b.size(), f);
                r.emplace_back("decode_scene_flow", lcm(err, "ok"));
            } else if (target == "fuzz_lcm_ego_motion") {
                lidarflow_ego_motion_t m;
                const std::string err = bridge::decode_ego_motion(b.data(), b.size(), m);
                r.emplace_back("decode_ego_motion", lcm(err, err.empty() ? "ok state " + std::to_string(m.state) : ""));
            } else if (target == "fuzz_lcm_status") {
                bridge::StatusMessage s;
                const std::string err = bridge::decode_status(b.data(), b.size(), s);
                r.emplace_back("decode_status",
                               lcm(err, err.empty() ? "ok lost_in_transport " +
                                                          std::to_string(s.fields.stereo_lost_in_transport) +
                                                          " last_error '" + s.last_error + "'"
                                                    : ""));
            } else if (target == "fuzz_lcm_bot_image") {
                int64_t utime = 0;
                const std::string err = bridge::check_bot_image(b.data(), b.size(), &utime);
                r.emplace_back("check_bot_image", lcm(err, "ok utime " + std::to_string(utime)));
            } else if (target == "fuzz_kitti_png") {
                const std::string p = seed.string();
                r.emplace_back("read_disparity_png", outcome([&] {
                                   const DisparityMap d = io::read_disparity_png(p);
                                   return "ok " + std::to_string(d.cols) + "x" + std::to_string(d.rows);
                               }));
                r.emplace_back("read_flow_png", outcome([&] {
                                   const FlowField f = io::read_flow_png(p);
                                   return "ok " + std::to_string(f.width()) + "x" + std::to_string(f.height());
                               }));
                r.emplace_back("read_image", outcome([&] {
                                   const cv::Mat m = io::read_image(p);
                                   return "ok " + std::to_string(m.cols) + "x" + std::to_string(m.rows);
                               }));
            } else if (target == "fuzz_io_calibration") {
                r.emplace_back("parse_opencv_stereo", outcome([&] {
                                   const io::Rig rig = io::parse_opencv_stereo(text, seed.filename().string());
                                   return std::string("ok") + (rig.rectify ? " raw" : "");
                               }));
                const size_t cut = text.find("\n%%\n");
                r.emplace_back("parse_camera_info_pair", outcome([&] {
                                   if (cut == std::string::npos) return std::string("rejected: not a pair");
                                   const io::Rig rig = io::parse_camera_info_pair(text.substr(0, cut + 1), "left",
                                                                                  text.substr(cut + 4), "right");
                                   return std::string("ok") + (rig.rectify ? " raw" : "");
                               }));
            } else if (target == "fuzz_kitti_calib") {
                r.emplace_back("parse_calib_cam_to_cam", outcome([&] {
                                   const io::CamToCamCalib c = io::parse_calib_cam_to_cam(text, seed.filename().string());
                                   return "ok fx " + std::to_string(c.camera.fx);
                               }));
                r.emplace_back("parse_calib_velo_to_cam", outcome([&] {
                                   io::parse_calib_velo_to_cam(text, seed.filename().string());
                                   return std::string("ok");
                               }));
            } else {
                r.emplace_back("read_velodyne_bin", outcome([&] {
                                   const io::VelodyneScan s = io::read_velodyne_bin(seed.string());
                                   return "ok " + std::to_string(s.points.size()) + " points, " +
                                          std::to_string(s.dropped_nonfinite) + " dropped";
                               }));
            }
            const bool refuse = seed.filename().string().rfind("not_", 0) == 0;
            int accepted = 0;
            for (const auto &x : r) accepted += x.second.rfind("ok", 0) == 0;
            const bool as_meant = refuse ? accepted == 0 : accepted > 0;
            bad += !as_meant;
            std::printf("%s %s/%s (meant: %s)\n", as_meant ? "ok  " : "BAD ", t, seed.filename().c_str(),
                        refuse ? "refused by every reader" : "accepted");
            for (const auto &x : r) std::printf("       %-24s %s\n", x.first.c_str(), x.second.c_str());
        }
    }
    return bad;
}

}  // namespace

int main(int argc, char **argv) {
    const bool check = argc == 3 && std::string(argv[1]) == "--check";
    if (argc != 2 && !check) {
        std::fprintf(stderr, "usage: %s [--check] CORPUS_DIR (e.g. tests/fuzz/corpus)\n", argv[0]);
        return 2;
    }
    g_root = argv[argc - 1];
    try {
        if (check) {
            const int bad = check_seeds();
            std::printf("%d seed(s) not as meant\n", bad);
            return bad == 0 ? 0 : 1;
        }
        lcm_seeds();
        kitti_seeds();
        ply_seeds();
        result_file_seeds();
        capi_seeds();
    } catch (const std::exception &e) {
        std::fprintf(stderr, "make_corpus: %s\n", e.what());
        return 1;
    }
    return 0;
}
