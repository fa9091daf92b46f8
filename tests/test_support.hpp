// SPDX-License-Identifier: MIT
#pragma once
// Shared helpers for the C++ cmocka suites. Include this header LAST: cmocka defines macros
// (fail(), ...) that break standard/OpenCV headers included after it.
// cmocka's skip() and assertion failures longjmp past C++ destructors: call skip() before any
// object that owns heap memory is alive in the test function (else LeakSanitizer reports it).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <sys/wait.h>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "core/maps.hpp"
#include "core/sanitizers.hpp"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
// cmocka 1.1 has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

namespace lidarflow::test {

// True when f throws lidarflow::Error with exactly `code`; prints any other code it sees.
inline bool throws_code(ErrorCode code, const std::function<void()> &f) {
    try {
        f();
    } catch (const Error &e) {
        if (e.code() != code) std::printf("unexpected error code %d: %s\n", static_cast<int>(e.code()), e.what());
        return e.code() == code;
    }
    return false;
}

// The ErrorCode thrown by f(); fails the test when f does not throw lidarflow::Error.
template <class F>
ErrorCode error_code_of(F &&f) {
    try {
        f();
    } catch (const Error &e) {
        return e.code();
    }
    fail_msg("expected a lidarflow::Error");
    return ErrorCode::Internal;
}

// The message of the lidarflow::Error thrown by f(); fails the test when f does not throw one.
template <class F>
std::string error_message_of(F &&f) {
    try {
        f();
    } catch (const Error &e) {
        return e.what();
    }
    fail_msg("expected a lidarflow::Error");
    return "";
}

// Fails the test unless f throws lidarflow::Error with exactly `code`.
template <class F>
void expect_error(F &&f, ErrorCode code) {
    assert_int_equal(static_cast<int>(error_code_of(std::forward<F>(f))), static_cast<int>(code));
}

// Path of the shared KITTI training folder, or "" when LIDARFLOW_KITTI_DIR is unset/missing.
inline std::string kitti_dir() {
    const char *d = std::getenv("LIDARFLOW_KITTI_DIR");
    if (!d || !*d || !std::filesystem::is_directory(std::filesystem::path(d) / "image_2")) return "";
    return d;
}

// The shared KITTI frames an accuracy check scores: both, or under the sanitizers (4x slower,
// and there for memory and threading errors, not figures) the first only. A bound on the mean of
// the frames applies only when every frame ran (kitti_all_frames()).
inline std::vector<std::string> kitti_ids() {
    if (LIDARFLOW_SANITIZED) return {"000002"};
    return {"000002", "000003"};
}
inline bool kitti_all_frames() { return kitti_ids().size() == 2; }

// For suites that only make sense on the real KITTI frames: exits with CTest's skip code.
inline std::string kitti_dir_or_skip(const char *suite) {
    std::string d = kitti_dir();
    if (d.empty()) {
        std::printf("%s: skipped: LIDARFLOW_KITTI_DIR is not set to a KITTI training folder\n", suite);
        std::exit(77);
    }
    return d;
}

// A fresh, empty scratch directory for one test (under the build tree when run by CTest).
inline std::filesystem::path scratch_dir(const std::string &name) {
    const char *base = std::getenv("LIDARFLOW_TEST_TMP");
    std::filesystem::path p = base && *base ? std::filesystem::path(base)
                                            : std::filesystem::temp_directory_path() / "lidarflow-tests";
    p /= name;
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p;
}

// The temporary files (".tmp-*", as the CLI names them while writing) anywhere under `folder`.
inline std::vector<std::string> temporaries(const std::filesystem::path &folder) {
    std::vector<std::string> t;
    for (const auto &e : std::filesystem::recursive_directory_iterator(folder))
        if (e.path().filename().string().rfind(".tmp-", 0) == 0) t.push_back(e.path().string());
    return t;
}

// What `lidarflow ARGS` printed and returned. code -1: killed by a signal.
struct CliRun {
    int code = -1;
    std::string output;  // stdout and stderr together
};

// What a shell command printed (stdout and stderr together) and returned.
inline CliRun run_shell(const std::string &cmd) {
    FILE *p = popen((cmd + " 2>&1").c_str(), "r");
    assert_non_null(p);
    CliRun r;
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
    const int status = pclose(p);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

// Runs the CLI that CTest names in LIDARFLOW_CLI with stdout + stderr piped to the test, as
// when a user pipes the program: no terminal. ARGS is shell text (quote paths with quoted()).
inline CliRun run_cli(const std::string &args) {
    const char *cli = std::getenv("LIDARFLOW_CLI");
    if (!cli || !*cli) fail_msg("LIDARFLOW_CLI is not set (run through ctest)");
    return run_shell(std::string("'") + cli + "' " + args);
}

// Fails (printing the output) unless the run printed `what`.
inline void expect_output_has(const CliRun &r, const std::string &what) {
    if (r.output.find(what) != std::string::npos) return;
    std::printf("%s", r.output.c_str());
    fail_msg("expected \"%s\" in the output above", what.c_str());
}

// Fails (printing the output) unless the run exited with `code`.
inline void expect_exit(const CliRun &r, int code) {
    if (r.code == code) return;
    std::printf("%s", r.output.c_str());
    fail_msg("expected exit %d, got %d%s", code, r.code, r.code == 124 ? " (timed out: blocked)" : "");
}

// A drive's frame file stem: 10 digits.
inline std::string frame_name(long k) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "%010ld", k);
    return buf;
}

// A path as one single-quoted shell word.
inline std::string quoted(const std::filesystem::path &p) { return "'" + p.string() + "'"; }

// Share [%] of the pixels whose disparity differs by more than 1 px between two maps of one size.
inline double share_off(const DisparityMap &x, const DisparityMap &y) {
    cv::Mat1f d;
    cv::absdiff(x, y, d);
    return 100.0 * cv::countNonZero(d > 1) / static_cast<double>(d.total());
}

}  // namespace lidarflow::test
