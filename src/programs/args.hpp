// SPDX-License-Identifier: MIT
#pragma once
// Minimal, strict option parser shared by the lidarflow sub-commands and lidarflow-lcm-bridge:
// --name value, --name=value and --flag. Unknown options (with a "did you mean"), missing values
// and malformed numbers throw UsageError; both programs exit 2 on it.
// No dependency on the estimator's core: the bridge reaches the estimator through the C ABI only.
#include <stdexcept>
#include <string>
#include <vector>

namespace lidarflow::cli {

// A bad command line. Its own type (not lidarflow::Error) so that the bridge needs no core header.
class UsageError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

struct OptionSpec {
    std::string name;   // without leading dashes
    bool takes_value;   // false: a flag
    std::string help;   // one line; for options with a value, start with the value's name
};

class Args {
public:
    // argv[0] is the program or sub-command name; parsing starts at argv[1]. `command` starts
    // every error message.
    Args(std::string command, int argc, char **argv, std::vector<OptionSpec> spec);

    bool help_requested() const { return help_; }
    // "usage: lidarflow COMMAND [options]" and a line per option (the CLI's sub-commands).
    std::string usage() const;

    bool has(const std::string &name) const;
    bool flag(const std::string &name) const { return has(name); }
    std::string str(const std::string &name, const std::string &def) const;
    // Every value given for a repeatable option, in command-line order.
    std::vector<std::string> all(const std::string &name) const;
    std::string required(const std::string &name) const;
    int integer(const std::string &name, int def) const;
    double number(const std::string &name, double def) const;
    // number(), and within [lo, hi].
    double number_in(const std::string &name, double def, double lo, double hi) const;
    // Comma-separated list ("000002,000003"); empty when absent.
    std::vector<std::string> list(const std::string &name) const;

private:
    const OptionSpec *find(const std::string &name) const;
    std::string command_;
    std::vector<OptionSpec> spec_;
    std::vector<std::pair<std::string, std::string>> values_;
    bool help_ = false;
};

// "a,b,,c" -> {"a", "b", "c"}: the items of a comma-separated list, empty ones dropped.
std::vector<std::string> split_list(const std::string &text);

}  // namespace lidarflow::cli
