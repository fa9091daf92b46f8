// SPDX-License-Identifier: MIT
// lidarflow options: every option key of the C ABI (the `--set` keys) with its type, bounds and
// default, read from the option key table (src/pipeline/option_keys.cpp) so the listing cannot
// drift from what is accepted.
#include <cstdio>

#include "args.hpp"
#include "commands.hpp"
#include "pipeline/option_keys.hpp"

namespace lidarflow::cli {
namespace {

int list_options(int argc, char **argv) {
    Args args("options", argc, argv, {});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    std::printf("%-40s %-7s %-32s %s\n", "key", "type", "accepted", "default");
    for (const pipeline::OptionKeyDescription &d : pipeline::describe_option_keys())
        std::printf("%-40s %-7s %-32s %s\n", d.name.c_str(), d.type.c_str(),
                    d.bounds.empty() ? "-" : d.bounds.c_str(), d.defaults.c_str());
    std::printf("\npresets (key \"preset\", CLI --preset): default, paper, balanced, fast, realtime; set it before other keys.\n"
                "Use: lidarflow run|kitti|demo --set KEY=VALUE,..; lf_options_set_* in C; options={...} in "
                "Python; --option KEY=VALUE in lidarflow-lcm-bridge.\n");
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(options, "options", "list every estimator option key: type, accepted values, default",
                  list_options, 90);

}  // namespace lidarflow::cli
