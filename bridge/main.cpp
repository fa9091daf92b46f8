// SPDX-License-Identifier: MIT
// lidarflow-lcm-bridge: runs the lidarflow estimator on stereo (+ LiDAR) frames from LCM and
// publishes the scene flow and a status heartbeat. Uses only lidarflow's C ABI.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include "args.hpp"
#include "bridge_core.hpp"
#include "calib_file.hpp"
#include "heap_policy.hpp"
#include "lcm_url.hpp"
#include "progress.hpp"
#include "replay.hpp"

namespace {

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

const char *kUsage =
    "usage: lidarflow-lcm-bridge [options]\n"
    "  --lcm-url URL            LCM provider (default: $LCM_DEFAULT_URL or LCM's default); a udpm://\n"
    "                           URL gets recv_buf_size (16 MiB) capped at net.core.rmem_max\n"
    "  --stereo-channel NAME    stereo_t or bot_core.images_t input (default LIDARFLOW_STEREO)\n"
    "  --left-channel NAME --right-channel NAME\n"
    "                           a camera per channel (bot_core.image_t each) instead of the stereo\n"
    "                           channel: images of equal utime make a stereo frame\n"
    "  --pair-wait-ms T         an image waits up to T ms for its partner (default 100)\n"
    "  --pair-buffer N          images waiting per camera, oldest dropped first (default 8)\n"
    "  --lidar-channel NAME     lidar_t or bot_core.pointcloud_t input (default LIDARFLOW_LIDAR)\n"
    "  --calib-channel NAME     calibration_t input (default LIDARFLOW_CALIB)\n"
    "  --flow-channel NAME      scene_flow_t output (default LIDARFLOW_FLOW)\n"
    "  --ego-channel NAME       ego_motion_t output, one per result (default LIDARFLOW_EGO_MOTION)\n"
    "  --quality-channel NAME   quality_t output (input quality), one per result (default LIDARFLOW_QUALITY)\n"
    "  --status-channel NAME    status_t output (default LIDARFLOW_STATUS)\n"
    "  --calib FILE[,FILE]      fixed calibration: KITTI calib_cam_to_cam.txt, OpenCV stereo file or\n"
    "                           LEFT,RIGHT camera_info YAMLs (docs/CALIBRATION.md); default: the channel\n"
    "  --lidar-tolerance-ms T   pair a LiDAR sweep with the stereo frame within T ms (default 20)\n"
    "  --lidar-wait-ms T        wait up to T ms for a sweep that arrives after its frame (default 30)\n"
    "  --lidar-to-camera M      LiDAR -> left rectified camera, 16 numbers (row-major 4x4, comma- or\n"
    "                           space-separated) for bot_core.pointcloud_t sweeps (LiDAR frame)\n"
    "  --lidar-buffer N         sweeps kept for pairing (default 8)\n"
    "  --queue N                frames waiting for the estimator, latest wins (default 1)\n"
    "  --encoding E             float32 | int16 (1/64 px fixed point; default)\n"
    "  --step N                 publish every N-th pixel in x and y (default 1)\n"
    "  --option KEY=VALUE       estimator option (lidarflow.h keys), repeatable; threads defaults\n"
    "                           to the library's: every usable CPU, fewer while others are busy\n"
    "  --shard K/N              one of N processes sharing the stream: compute only the pairs whose\n"
    "                           t1 frame index % N == K (index: stereo_t.frame_number, else arrival\n"
    "                           order); the queue default becomes 2 (a pair)\n"
    "  --shard-timeout S        with --shard: a shard with no status for S seconds is taken for dead\n"
    "                           and its pairs counted as lost (default 3 status periods; 0 = off)\n"
    "  --shard-key FILE         with --shard: a key shared by the shards (>= 16 bytes, e.g. `openssl rand\n"
    "                           -hex 32`): statuses and results carry an HMAC-SHA256 (on STATUS_CHANNEL_MAC),\n"
    "                           and the shard watch ignores (and counts) those without a valid one, and\n"
    "                           statuses that answer none of its own recent ones (a recording played again)\n"
    "  --status-period S        status every S seconds (default 1; 0 = only at exit)\n"
    "  --verbose                a line per published result, and the library's info messages\n"
    "  --quiet                  no --replay progress lines and no library messages (errors and the\n"
    "                           summary stay)\n"
    "  --replay IN.log --out OUT.log\n"
    "                           offline: every frame of the LCM log IN.log in log order at the\n"
    "                           estimator's pace (no network, nothing stale), results and status into\n"
    "                           OUT.log on IN.log's clock (--status-period in log seconds); exit 3\n"
    "                           and a line per frame when a frame was not processed\n"
    "  --frames A:B             with --replay: stereo frames A..B only (0.. in log order, both included)\n"
    "  --warm-up N              with --replay --frames A:B: start the stream N stereo frames before A\n"
    "                           (0..1000, default 0): their pairs feed the stream's priors, not written\n"
    "                           or counted; warmed up from frame 0, A..B get the whole log's results\n"
    "  --version                print the lidarflow library version and exit\n"
    "  --help                   print this help and exit\n"
    "Stops cleanly on SIGINT / SIGTERM (publishes a final status).\n"
    "\n"
    "Exit status:\n"
    "  0  stopped by SIGINT / SIGTERM; --replay: every stereo frame processed\n"
    "  1  LCM cannot be opened or fails, a --calib file cannot be read, the library refuses an\n"
    "     --option value or the calibration; --replay: a log cannot be read or written\n"
    "  2  a bad command line\n"
    "  3  --replay: some frames not processed (a LOST: line each), or interrupted\n";

// --replay: 0 when every stereo frame of the log was processed, 3 when some were not (listed),
// 1 when the logs cannot be read or written.
int replay(const lidarflow::bridge::BridgeConfig &config, const std::string &in, const std::string &out,
           const lidarflow::bridge::ReplayFrames &frames, bool quiet) {
    using namespace lidarflow::bridge;
    ReplayReport r;
    const double t0 = monotonic_seconds();
    // Progress by the share of the log read (frames per log are not known before the end).
    std::error_code size_error;
    const auto log_bytes = std::filesystem::file_size(in, size_error);
    const double total = size_error ? 0.0 : static_cast<double>(log_bytes);
    lidarflow::cli::Progress bar(!quiet, isatty(fileno(stderr)) != 0, 5.0);
    const std::string err = run_replay(config, in, out, &r, &g_stop, frames, [&](int64_t stereo_frames, int64_t bytes) {
        const std::string share = total > 0 ? printf_string(", %.0f %% of the log", 100.0 * static_cast<double>(bytes) / total)
                                            : std::string();
        bar.update(static_cast<double>(bytes), total,
                   printf_string("lidarflow-lcm-bridge: replay: stereo frame %lld%s", static_cast<long long>(stereo_frames),
                                 share.c_str()));
    });
    bar.finish();
    const double seconds = monotonic_seconds() - t0;
    if (!err.empty()) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: replay of %s: %s\n", in.c_str(), err.c_str());
        return 1;
    }
    const Counters &c = r.counters;
    for (const std::string &line : r.notes) std::fprintf(stderr, "lidarflow-lcm-bridge: note: %s\n", line.c_str());
    for (const std::string &line : r.lost) std::fprintf(stderr, "lidarflow-lcm-bridge: LOST: %s\n", line.c_str());
    if (r.interrupted)
        std::fprintf(stderr, "lidarflow-lcm-bridge: LOST: interrupted, %s%lld stereo frame(s) not replayed%s\n",
                     r.not_replayed_counted ? "" : "at least ", (long long)r.stereo_not_replayed,
                     r.not_replayed_counted ? "" : " (the rest of the log was not counted: exit within a second)");
    std::fprintf(stderr,
                 "lidarflow-lcm-bridge: replayed %s -> %s in %.1f s: %lld events (stereo %lld, lidar %lld, "
                 "calibration %lld, other channels %lld, left out); stereo processed %lld, dropped %lld, missing "
                 "from the log %lld; lidar malformed %lld, rejected %lld; calibration malformed %lld; %lld results, "
                 "%lld status messages written; pairs lost to a calibration change %lld\n",
                 in.c_str(), out.c_str(), seconds, (long long)r.events, (long long)r.stereo_events,
                 (long long)r.lidar_events, (long long)r.calibration_events, (long long)r.other_events,
                 (long long)c.stereo_processed, (long long)c.dropped(), (long long)c.stereo_lost_in_transport,
                 (long long)c.lidar_malformed, (long long)c.lidar_rejected, (long long)c.calibration_malformed,
                 (long long)r.flows_written, (long long)r.status_written, (long long)c.pairs_lost_calibration_change);
    std::fprintf(stderr, "lidarflow-lcm-bridge: input quality of the results: %s\n", c.quality_text().c_str());
    if (frames.first > 0 || frames.last < INT64_MAX) {
        // Fed: what the estimator took (a warm-up frame dropped, e.g. before any calibration, fed nothing).
        const std::string before =
            frames.warm_up > 0
                ? printf_string(", warm-up %lld: the last %lld handed over, %lld fed to the estimator, %lld pairs "
                                "computed and not written",
                                (long long)frames.warm_up, (long long)r.stereo_warm_up, (long long)c.warm_up_fed,
                                (long long)c.warm_up_pairs)
                : std::string(" not computed");
        std::fprintf(stderr, "lidarflow-lcm-bridge: frames %lld:%lld: %lld stereo frame(s) before the range%s, %s\n",
                     (long long)frames.first, (long long)frames.last, (long long)r.stereo_before_range, before.c_str(),
                     r.stopped_after_range ? "stopped at the frame after it"
                                           : printf_string("the log ended after %lld stereo frame(s)",
                                                           (long long)r.stereo_in_log).c_str());
    }
    return r.lost.empty() && !r.interrupted && r.stereo_not_replayed == 0 ? 0 : 3;
}

// Every option of kUsage; the parser (src/programs, shared with the CLI) suggests the nearest
// name for a typo. help stays empty: kUsage is the help text.
std::vector<lidarflow::cli::OptionSpec> bridge_options() {
    std::vector<lidarflow::cli::OptionSpec> spec;
    for (const char *name : {"lcm-url", "stereo-channel", "left-channel", "right-channel", "pair-wait-ms",
                             "pair-buffer", "lidar-channel", "calib-channel", "flow-channel", "ego-channel", "quality-channel",
                             "status-channel", "calib", "lidar-tolerance-ms", "lidar-wait-ms", "lidar-to-camera",
                             "lidar-buffer", "queue", "shard", "shard-timeout", "shard-key", "encoding", "step", "option", "status-period", "replay",
                             "out", "frames", "warm-up"})
        spec.push_back({name, true, ""});
    spec.push_back({"verbose", false, ""});
    spec.push_back({"quiet", false, ""});
    spec.push_back({"version", false, ""});
    return spec;
}

// A library message on stderr, at most kBurst lines per kWindowS seconds (a warning of every
// frame must not flood the log); the lines held back are counted in the next one shown.
void library_message(int32_t level, const char *message, void *) {
    constexpr int kBurst = 10;
    constexpr double kWindowS = 10.0;
    static std::mutex mutex;
    static double window_start = -1e300;
    static int in_window = 0;
    static long long held_back = 0;
    const std::lock_guard<std::mutex> lock(mutex);
    const double now = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    if (now - window_start >= kWindowS) {
        window_start = now;
        in_window = 0;
    }
    if (++in_window > kBurst) {
        ++held_back;
        return;
    }
    const char *name = level >= LF_LOG_ERROR ? "error" : level >= LF_LOG_WARNING ? "warning" : level >= LF_LOG_INFO ? "info" : "debug";
    if (held_back > 0)
        std::fprintf(stderr, "lidarflow-lcm-bridge: library %s: %s (%lld earlier library lines held back)\n", name, message,
                     held_back);
    else
        std::fprintf(stderr, "lidarflow-lcm-bridge: library %s: %s\n", name, message);
    held_back = 0;
}

// The command line into config; false (after a message on stderr) when it is bad.
bool parse_command_line(int argc, char **argv, lidarflow::bridge::BridgeConfig *config, std::string *url,
                        std::string *calib_file, std::string *replay_in, std::string *replay_out, bool *queue_given,
                        bool *quiet, lidarflow::bridge::ReplayFrames *frames) {
    using namespace lidarflow::bridge;
    const lidarflow::cli::Args args("lidarflow-lcm-bridge", argc, argv, bridge_options());
    *url = args.str("lcm-url", "");
    *replay_in = args.str("replay", "");
    *replay_out = args.str("out", "");
    *calib_file = args.str("calib", "");
    config->stereo_channel = args.str("stereo-channel", config->stereo_channel);
    config->left_channel = args.str("left-channel", "");
    config->right_channel = args.str("right-channel", "");
    if (config->left_channel.empty() != config->right_channel.empty() ||
        (!config->left_channel.empty() && config->left_channel == config->right_channel)) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --left-channel and --right-channel go together, on two "
                             "different channels\n");
        return false;
    }
    config->pair_wait_ms = static_cast<int>(args.number_in("pair-wait-ms", config->pair_wait_ms, 0, 10000));
    config->pair_buffer = static_cast<int>(args.number_in("pair-buffer", config->pair_buffer, 1, 1000));
    config->lidar_channel = args.str("lidar-channel", config->lidar_channel);
    config->calibration_channel = args.str("calib-channel", config->calibration_channel);
    config->flow_channel = args.str("flow-channel", config->flow_channel);
    config->status_channel = args.str("status-channel", config->status_channel);
    config->ego_channel = args.str("ego-channel", config->ego_channel);
    if (config->ego_channel == config->flow_channel || config->ego_channel == config->status_channel) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --ego-channel must differ from the flow and status channels\n");
        return false;
    }
    config->quality_channel = args.str("quality-channel", config->quality_channel);
    if (config->quality_channel == config->flow_channel || config->quality_channel == config->status_channel ||
        config->quality_channel == config->ego_channel) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --quality-channel must differ from the flow, ego and status channels\n");
        return false;
    }
    config->verbose = args.flag("verbose");
    *quiet = args.flag("quiet");
    if (*quiet && config->verbose) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --quiet and --verbose exclude each other\n");
        return false;
    }
    if (args.has("lidar-to-camera")) {
        const std::string v = args.str("lidar-to-camera", "");
        std::string text = v;
        std::replace(text.begin(), text.end(), ',', ' ');
        char *p = &text[0];
        int n = 0;
        for (char *end = nullptr; n < 16; ++n, p = end) {
            errno = 0;
            config->lidar_to_camera[n] = std::strtod(p, &end);
            if (end == p || errno != 0) break;
        }
        while (*p == ' ') ++p;
        if (n != 16 || *p != '\0') {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --lidar-to-camera %s: expected 16 numbers\n", v.c_str());
            return false;
        }
        config->have_lidar_to_camera = true;
    }
    if (args.has("lidar-tolerance-ms"))
        config->lidar_tolerance_us = static_cast<int64_t>(1000 * args.number_in("lidar-tolerance-ms", 0, 0, 1e6));
    config->lidar_wait_ms = static_cast<int>(args.number_in("lidar-wait-ms", config->lidar_wait_ms, 0, 10000));
    config->lidar_buffer = static_cast<int>(args.number_in("lidar-buffer", config->lidar_buffer, 1, 1000));
    config->queue_capacity = static_cast<int>(args.number_in("queue", config->queue_capacity, 1, 1000));
    *queue_given = args.has("queue");
    if (args.has("shard")) {
        const std::string v = args.str("shard", "");
        int k = -1, n = 0, used = 0;
        if (std::sscanf(v.c_str(), "%d/%d%n", &k, &n, &used) != 2 || v[static_cast<size_t>(used)] != '\0' || n < 1 ||
            n > 1000 || k < 0 || k >= n) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --shard %s: expected K/N with 0 <= K < N <= 1000\n", v.c_str());
            return false;
        }
        config->shard_index = k;
        config->shard_count = n;
    }
    if (args.has("shard-timeout")) config->shard_timeout_s = args.number_in("shard-timeout", 0, 0, 3600);
    if (args.has("shard-key")) {
        const std::string err = read_shard_key(args.str("shard-key", ""), &config->shard_key);
        if (!err.empty()) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --shard-key %s\n", err.c_str());
            return false;
        }
        if (config->shard_count < 2) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --shard-key needs --shard K/N with N > 1\n");
            return false;
        }
    }
    if (args.has("frames")) {
        const std::string v = args.str("frames", "");
        long long a = -1, b = -1;
        int used = 0;
        if (replay_in->empty() || std::sscanf(v.c_str(), "%lld:%lld%n", &a, &b, &used) != 2 ||
            v[static_cast<size_t>(used)] != '\0' || a < 0 || b <= a) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --frames %s: expected A:B with 0 <= A < B, with --replay\n",
                         v.c_str());
            return false;
        }
        frames->first = a;
        frames->last = b;
    }
    if (args.has("warm-up")) {
        // Refused rather than ignored: a live stream has no frames before it to warm up on.
        const int n = args.integer("warm-up", 0);
        if (replay_in->empty() || n < 0 || n > 1000) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --warm-up %s: expected a number of frames in [0, 1000], with "
                                 "--replay\n",
                         args.str("warm-up", "").c_str());
            return false;
        }
        frames->warm_up = n;
    }
    config->step = static_cast<int>(args.number_in("step", config->step, 1, 16));
    config->status_period_s = args.number_in("status-period", config->status_period_s, 0, 3600);
    if (config->shard_timeout_s > 0 && (config->shard_count < 2 || config->status_period_s <= 0)) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --shard-timeout needs --shard K/N with N > 1 and a "
                             "--status-period > 0 (the shards' heartbeats)\n");
        return false;
    }
    if (args.has("encoding")) {
        const std::string v = args.str("encoding", "");
        if (!parse_flow_encoding(v.c_str(), &config->encoding)) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --encoding %s: expected float32 or int16\n", v.c_str());
            return false;
        }
    }
    for (const std::string &v : args.all("option")) {
        const size_t eq = v.find('=');
        if (eq == std::string::npos || eq == 0) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --option %s: expected KEY=VALUE\n", v.c_str());
            return false;
        }
        const std::string key = v.substr(0, eq);
        config->options.emplace_back(key, v.substr(eq + 1));
    }
    return true;
}

}  // namespace

int main(int argc, char **argv) {
    using namespace lidarflow::bridge;
    lidarflow::tools::apply_heap_policy();
    BridgeConfig config;
    std::string url, calib_file, replay_in, replay_out;
    bool queue_given = false, quiet = false;
    ReplayFrames frames;
    // --help and --version answer before anything else is checked, as they always did.
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") {
            std::printf("%s", kUsage);
            return 0;
        }
        if (a == "--version") {
            std::printf("lidarflow-lcm-bridge %s (ABI %u)\n", lf_version_string(), lf_abi_major());
            return 0;
        }
    }
    try {
        if (!parse_command_line(argc, argv, &config, &url, &calib_file, &replay_in, &replay_out, &queue_given, &quiet,
                                &frames))
            return 2;
    } catch (const lidarflow::cli::UsageError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    }
    // A shard's frames come in pairs (t0, t1): room for both, or a t0 would go stale behind
    // the pair in progress.
    if (config.shard_count > 1 && !queue_given) config.queue_capacity = 2;
    if (!calib_file.empty()) {
        const std::string err = read_calibration(calib_file, &config.calibration);
        if (!err.empty()) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: --calib %s\n", err.c_str());
            return 1;
        }
        config.fixed_calibration = true;
    }

    if (replay_in.empty() != replay_out.empty() || (!replay_in.empty() && !url.empty())) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --replay and --out go together, and without --lcm-url\n");
        return 2;
    }
    if (!replay_in.empty() && !config.left_channel.empty()) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: --replay takes stereo frames from the stereo channel only "
                             "(a log replays in lock-step per stereo message; pairing two camera channels waits on\n"
                             "arrival times, which a log does not replay: use --left-channel/--right-channel live)\n");
        return 2;
    }
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    // The library's own messages join the bridge's log: warnings always, the rest with --verbose.
    if (!quiet) lf_set_log_callback(library_message, config.verbose ? LF_LOG_INFO : LF_LOG_WARNING, nullptr);
    if (!replay_in.empty()) return replay(config, replay_in, replay_out, frames, quiet);

    // Ask udpm for the receive buffer the kernel grants (LCM warns on anything more), and say
    // once how to raise the kernel's limit when it is below what large images need.
    const ReceiveBufferFit fit = fit_receive_buffer(effective_lcm_url(url), read_rmem_max());
    if (fit.limited())
        std::fprintf(stderr,
                     "lidarflow-lcm-bridge: note: UDP receive buffer %lld bytes (the kernel's net.core.rmem_max), "
                     "%lld wanted; large images may lose fragments. Raise the limit as root: "
                     "sysctl -w net.core.rmem_max=%lld\n",
                     fit.requested, fit.wanted, fit.wanted);
    lcm_t *lcm = lcm_create(fit.url.c_str());
    if (!lcm) {
        std::fprintf(stderr, "lidarflow-lcm-bridge: cannot open LCM '%s'\n", fit.url.c_str());
        return 1;
    }

    std::string error;
    int rc = 0;
    {
        std::unique_ptr<Bridge> bridge = Bridge::create(config, lcm, &error);
        if (!bridge) {
            std::fprintf(stderr, "lidarflow-lcm-bridge: %s\n", error.c_str());
            lcm_destroy(lcm);
            return 1;
        }
        std::fprintf(stderr, "lidarflow-lcm-bridge: lidarflow %s, listening on %s / %s / %s%s, publishing %s / %s / %s / %s\n",
                     lf_version_string(),
                     config.left_channel.empty() ? config.stereo_channel.c_str()
                                                 : (config.left_channel + " + " + config.right_channel).c_str(),
                     config.lidar_channel.c_str(),
                     config.calibration_channel.c_str(), config.fixed_calibration ? " (calibration from --calib)" : "",
                     config.flow_channel.c_str(), config.ego_channel.c_str(), config.quality_channel.c_str(),
                     config.status_channel.c_str());
        while (!g_stop) {
            if (bridge->run_once(100) != 0) {
                std::fprintf(stderr, "lidarflow-lcm-bridge: LCM receive failed; stopping\n");
                rc = 1;
                break;
            }
        }
        bridge->stop();
        const Counters c = bridge->counters();
        std::fprintf(stderr,
                     "lidarflow-lcm-bridge: stopped. stereo received %lld, processed %lld, dropped %lld (stale %lld, "
                     "out of order %lld, no calibration %lld, calibration mismatch %lld, malformed %lld, estimator "
                     "%lld, shutdown %lld, unpaired %lld); skipped for other shards %lld; results %lld, latency mean %.1f ms max %.1f ms (estimator mean %.1f ms); "
                     "shards dead %d, their pairs lost %lld; pairs lost to a calibration change %lld; shard messages "
                     "refused (no valid MAC) %lld, shard index conflicts %lld, shard results ignored %lld\n",
                     (long long)c.stereo_received, (long long)c.stereo_processed, (long long)c.dropped(),
                     (long long)c.dropped_stale, (long long)c.dropped_out_of_order, (long long)c.dropped_no_calibration,
                     (long long)c.dropped_calibration_mismatch, (long long)c.dropped_malformed,
                     (long long)c.dropped_estimator_error, (long long)c.dropped_shutdown, (long long)c.dropped_unpaired,
                     (long long)c.skipped_other_shard, (long long)c.results_published, c.latency_mean_ms, c.latency_max_ms,
                     c.compute_mean_ms, c.shards_dead, (long long)c.pairs_lost_dead_shard,
                     (long long)c.pairs_lost_calibration_change,
                     (long long)c.shard_messages_refused, (long long)c.shard_index_conflicts,
                     (long long)c.shard_results_ignored);
        std::fprintf(stderr, "lidarflow-lcm-bridge: input quality of the results: %s\n", c.quality_text().c_str());
    }
    lcm_destroy(lcm);
    return rc;
}
