// SPDX-License-Identifier: MIT
// lidarflow: the command-line program. One binary, one sub-command per job.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include "args.hpp"
#include "commands.hpp"
#include "heap_policy.hpp"
#include "log.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "lidarflow/lidarflow_version.h"

namespace lidarflow::cli {
std::vector<Command> &command_registry() {
    static std::vector<Command> registry;
    return registry;
}

namespace {
bool g_reading_inputs = false;  // one command per process
}  // namespace
void inputs_begin() { g_reading_inputs = true; }
bool reading_inputs() { return g_reading_inputs; }
}  // namespace lidarflow::cli

namespace {

using lidarflow::cli::Command;

void print_usage(FILE *f) {
    std::fprintf(f, "lidarflow %s - dense scene flow from stereo images and sparse LiDAR\n\n",
                 LF_VERSION_STRING);
    std::fprintf(f, "usage: lidarflow <command> [options]   (lidarflow <command> --help)\n\ncommands:\n");
    auto cmds = lidarflow::cli::command_registry();
    std::sort(cmds.begin(), cmds.end(), [](const Command &a, const Command &b) { return a.order < b.order; });
    for (const Command &c : cmds) std::fprintf(f, "  %-14s %s\n", c.name, c.summary);
    std::fprintf(f, "\noptions:\n"
                    "  --help         this text; lidarflow <command> --help: the command's options\n"
                    "  --version      the version of lidarflow\n"
                    "  --quiet        (any command) only errors, on stderr\n"
                    "  --verbose      (any command) settings, per-step timings, the library's messages on stderr\n"
                    "\nexit status:\n"
                    "  0              success\n"
                    "  1              an error: an input that cannot be read or is malformed (also a calibration\n"
                    "                 file outside the accepted ranges), an output that cannot be written\n"
                    "  2              a bad command line: an unknown option or key, a value out of range\n"
                    "  3              sequence: some pairs lost to bad frames (the others were written)\n");
}

// The core's messages (what the library decided: points dropped, fallbacks), one line each.
void print_library_message(int32_t level, const char *message, void *) {
    const char *name = level >= 40 ? "error" : level >= 30 ? "warning" : level >= 20 ? "info" : "debug";
    std::fprintf(stderr, "lidarflow: %s: %s\n", name, message);
}

// Takes --quiet and --verbose off argv (after the sub-command's name) and sets the level; both
// at once is a usage error. Returns the new argc.
int take_verbosity_flags(int argc, char **argv, bool *help) {
    bool quiet = false, verbose = false;
    int n = 2;
    for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") *help = true;
        if (a == "--quiet") {
            quiet = true;
        } else if (a == "--verbose") {
            verbose = true;
        } else {
            argv[n++] = argv[i];
        }
    }
    argv[n] = nullptr;
    if (quiet && verbose) throw lidarflow::cli::UsageError("--quiet and --verbose exclude each other");
    lidarflow::cli::set_verbosity(quiet     ? lidarflow::cli::Verbosity::Quiet
                                  : verbose ? lidarflow::cli::Verbosity::Verbose
                                            : lidarflow::cli::Verbosity::Normal);
    if (verbose) lidarflow::log::set_sink(print_library_message, static_cast<int>(lidarflow::log::Level::Debug), nullptr);
    return n;
}

constexpr const char *kVerbosityHelp =
    "  --quiet               only errors (on stderr); nothing else on stdout or stderr\n"
    "  --verbose             more detail on stderr: settings, per-step timings, the library's\n"
    "                        messages (LiDAR points dropped, fallbacks)\n";

}  // namespace

int main(int argc, char **argv) {
    lidarflow::tools::apply_heap_policy();
    if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
        !std::strcmp(argv[1], "help")) {
        print_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    if (!std::strcmp(argv[1], "--version")) {
        std::printf("lidarflow %s\n", LF_VERSION_STRING);
        return 0;
    }
    for (const Command &c : lidarflow::cli::command_registry()) {
        if (std::strcmp(argv[1], c.name) != 0) continue;
        try {
            bool help = false;
            argc = take_verbosity_flags(argc, argv, &help);
            if (lidarflow::cli::verbosity() == lidarflow::cli::Verbosity::Quiet && !help) {
                // Reports go to stdout: with --quiet, nowhere. Errors still reach stderr.
                std::fflush(stdout);
                const int null = open("/dev/null", O_WRONLY);
                if (null >= 0) {
                    dup2(null, STDOUT_FILENO);
                    close(null);
                }
            }
            const lidarflow::cli::Stopwatch clock;
            const int rc = c.run(argc - 1, argv + 1);
            if (help) {
                std::printf("%s", kVerbosityHelp);
            } else {
                std::fflush(stdout);
                lidarflow::cli::detail("lidarflow %s: finished in %s (exit %d)\n", c.name,
                                       lidarflow::cli::format_duration(clock.seconds()).c_str(), rc);
            }
            return rc;
        } catch (const lidarflow::cli::UsageError &e) {
            std::fprintf(stderr, "lidarflow %s: error: %s\n", c.name, e.what());
            return 2;
        } catch (const lidarflow::Error &e) {
            std::fprintf(stderr, "lidarflow %s: error: %s\n", c.name, e.what());
            return e.code() == lidarflow::ErrorCode::InvalidArgument && !lidarflow::cli::reading_inputs() ? 2 : 1;
        } catch (const std::exception &e) {
            std::fprintf(stderr, "lidarflow %s: error: %s\n", c.name, e.what());
            return 1;
        }
    }
    std::fprintf(stderr, "lidarflow: unknown command '%s'\n\n", argv[1]);
    print_usage(stderr);
    return 2;
}
