// SPDX-License-Identifier: MIT
#pragma once
// Sub-command registry. Each cmd_*.cpp registers its own command with LIDARFLOW_COMMAND, so
// adding a command touches no other file. A command gets argv with argv[0] = its own name,
// returns the process exit code, and may throw lidarflow::Error (main reports it).
#include <vector>

namespace lidarflow::cli {

struct Command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv);
    int order;  // position in `lidarflow --help` (smaller first)
};

std::vector<Command> &command_registry();

// A command calls this once its command line is checked, before it reads its inputs. main's exit
// status for a lidarflow::Error of code InvalidArgument depends on it: before, a value given on
// the command line was out of range (2); after, the inputs were (an image too large, a frame with
// nothing to match: 1), as --help's exit statuses say. Main thread only.
void inputs_begin();
bool reading_inputs();

struct CommandRegistrar {
    explicit CommandRegistrar(const Command &c) { command_registry().push_back(c); }
};

}  // namespace lidarflow::cli

#define LIDARFLOW_COMMAND(ident, name, summary, fn, order) \
    static const ::lidarflow::cli::CommandRegistrar lidarflow_command_##ident({name, summary, fn, order})
