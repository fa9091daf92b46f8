// SPDX-License-Identifier: MIT
#pragma once
// Minimal, strict option parser for the lidarflow sub-commands: --name value and --flag.
// Unknown options, missing values and malformed numbers are errors (ErrorCode::InvalidArgument).
#include <string>
#include <vector>

namespace lidarflow::cli {

struct OptionSpec {
    std::string name;   // without leading dashes
    bool takes_value;   // false: a flag
    std::string help;   // one line; for options with a value, start with the value's name
};

class Args {
public:
    // argv[0] is the sub-command name; parsing starts at argv[1].
    Args(std::string command, int argc, char **argv, std::vector<OptionSpec> spec);

    bool help_requested() const { return help_; }
    std::string usage() const;

    bool has(const std::string &name) const;
    bool flag(const std::string &name) const { return has(name); }
    std::string str(const std::string &name, const std::string &def) const;
    std::string required(const std::string &name) const;
    int integer(const std::string &name, int def) const;
    double number(const std::string &name, double def) const;
    // Comma-separated list ("000002,000003"); empty when absent.
    std::vector<std::string> list(const std::string &name) const;

private:
    const OptionSpec *find(const std::string &name) const;
    std::string command_;
    std::vector<OptionSpec> spec_;
    std::vector<std::pair<std::string, std::string>> values_;
    bool help_ = false;
};

}  // namespace lidarflow::cli
