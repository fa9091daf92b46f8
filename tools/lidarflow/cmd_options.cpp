// SPDX-License-Identifier: MIT
// lidarflow options: every option key of the C ABI (the `--set` keys) with its type, bounds,
// default and one line of description, read from the option key table
// (src/pipeline/option_keys.cpp) so the listing cannot drift from what is accepted. With
// --preset NAME: each key's value under that preset, marked where it differs from "paper" (the
// field defaults).
#include <cstdio>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "pipeline/option_keys.hpp"

namespace lidarflow::cli {
namespace {

using pipeline::OptionKeyDescription;

constexpr const char *kPresets = "default, paper, balanced, fast, realtime";

void print_rows(const std::vector<OptionKeyDescription> &rows, const std::vector<OptionKeyDescription> *paper) {
    std::printf("%-40s %-7s %-32s %s\n", "key", "type", "accepted", paper ? "value" : "default");
    for (size_t i = 0; i < rows.size(); ++i) {
        const OptionKeyDescription &d = rows[i];
        std::string value = d.value;
        if (paper && d.name != "preset" && (*paper)[i].value != d.value) value += "  * (paper: " + (*paper)[i].value + ")";
        std::printf("%-40s %-7s %-32s %s\n", d.name.c_str(), d.type.c_str(), d.bounds.empty() ? "-" : d.bounds.c_str(),
                    value.c_str());
        std::printf("    %s\n", d.description.c_str());
    }
}

int list_options(int argc, char **argv) {
    Args args("options", argc, argv,
              {{"preset", true, "NAME  each key's value under this preset (" + std::string(kPresets) +
                                    "); * marks those that differ from \"paper\" (the field defaults)"}});
    if (args.help_requested()) {
        std::printf("%s", args.usage().c_str());
        return 0;
    }
    if (args.has("preset")) {
        const std::string name = args.str("preset", "");
        pipeline::OptionValues values;
        try {
            values = pipeline::preset_values(name, values);
        } catch (const Error &) {
            throw UsageError("unknown preset '" + name + "' (known: " + kPresets + ")");
        }
        const std::vector<OptionKeyDescription> paper =
            pipeline::describe_option_keys(pipeline::preset_values("paper", values));
        std::printf("preset \"%s\": every key's value; * = differs from preset \"paper\" (the field defaults)\n\n",
                    name.c_str());
        print_rows(pipeline::describe_option_keys(values), &paper);
        return 0;
    }
    print_rows(pipeline::describe_option_keys(), nullptr);
    std::printf("\npresets (key \"preset\", CLI --preset): %s; set it before other keys.\n"
                "Each preset's values: lidarflow options --preset NAME.\n"
                "Use: lidarflow run|kitti|demo --set KEY=VALUE,..; lf_options_set_* in C; options={...} in "
                "Python; --option KEY=VALUE in lidarflow-lcm-bridge.\n",
                kPresets);
    return 0;
}

}  // namespace

LIDARFLOW_COMMAND(options, "options", "list every estimator option key: type, accepted values, default, meaning",
                  list_options, 90);

}  // namespace lidarflow::cli
