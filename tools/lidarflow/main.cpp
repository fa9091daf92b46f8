// SPDX-License-Identifier: MIT
// lidarflow: the command-line program. One binary, one sub-command per job.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>

#include "args.hpp"
#include "commands.hpp"
#include "heap_policy.hpp"
#include "core/error.hpp"
#include "lidarflow/lidarflow.h"

namespace lidarflow::cli {
std::vector<Command> &command_registry() {
    static std::vector<Command> registry;
    return registry;
}
}  // namespace lidarflow::cli

namespace {

using lidarflow::cli::Command;

void print_usage(FILE *f) {
    std::fprintf(f, "lidarflow %s - dense scene flow from stereo images and sparse LiDAR\n\n",
                 lf_version_string());
    std::fprintf(f, "usage: lidarflow <command> [options]   (lidarflow <command> --help)\n\ncommands:\n");
    auto cmds = lidarflow::cli::command_registry();
    std::sort(cmds.begin(), cmds.end(), [](const Command &a, const Command &b) { return a.order < b.order; });
    for (const Command &c : cmds) std::fprintf(f, "  %-14s %s\n", c.name, c.summary);
}

}  // namespace

int main(int argc, char **argv) {
    lidarflow::tools::apply_heap_policy();
    if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
        !std::strcmp(argv[1], "help")) {
        print_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    if (!std::strcmp(argv[1], "--version")) {
        std::printf("lidarflow %s\n", lf_version_string());
        return 0;
    }
    for (const Command &c : lidarflow::cli::command_registry()) {
        if (std::strcmp(argv[1], c.name) != 0) continue;
        try {
            return c.run(argc - 1, argv + 1);
        } catch (const lidarflow::cli::UsageError &e) {
            std::fprintf(stderr, "lidarflow %s: error: %s\n", c.name, e.what());
            return 2;
        } catch (const lidarflow::Error &e) {
            std::fprintf(stderr, "lidarflow %s: error: %s\n", c.name, e.what());
            return e.code() == lidarflow::ErrorCode::InvalidArgument ? 2 : 1;
        } catch (const std::exception &e) {
            std::fprintf(stderr, "lidarflow %s: error: %s\n", c.name, e.what());
            return 1;
        }
    }
    std::fprintf(stderr, "lidarflow: unknown command '%s'\n\n", argv[1]);
    print_usage(stderr);
    return 2;
}
