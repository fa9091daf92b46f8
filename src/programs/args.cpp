// SPDX-License-Identifier: MIT
#include "args.hpp"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>

#include "core/closest_name.hpp"

namespace lidarflow::cli {
namespace {

void require(bool cond, const std::string &message) {
    if (!cond) throw UsageError(message);
}

}  // namespace

Args::Args(std::string command, int argc, char **argv, std::vector<OptionSpec> spec)
    : command_(std::move(command)), spec_(std::move(spec)) {
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "-h" || a == "--help") {
            help_ = true;
            continue;
        }
        require(a.rfind("--", 0) == 0 && a.size() > 2, command_ + ": unexpected argument '" + a + "' (see --help)");
        std::string name = a.substr(2), value;
        const auto eq = name.find('=');
        bool inline_value = eq != std::string::npos;
        if (inline_value) {
            value = name.substr(eq + 1);
            name = name.substr(0, eq);
        }
        const OptionSpec *s = find(name);
        if (s == nullptr) {
            std::vector<std::string> names;
            for (const OptionSpec &o : spec_) names.push_back(o.name);
            const std::string near = closest_name(name, names);
            throw UsageError(command_ + ": unknown option --" + name +
                             (near.empty() ? std::string() : " (did you mean --" + near + "?)") + " (see --help)");
        }
        if (s->takes_value && !inline_value) {
            require(i + 1 < argc, command_ + ": option --" + name + " needs a value");
            value = argv[++i];
        }
        require(s->takes_value || !inline_value, command_ + ": option --" + name + " takes no value");
        values_.emplace_back(name, value);
    }
}

const OptionSpec *Args::find(const std::string &name) const {
    for (const auto &s : spec_)
        if (s.name == name) return &s;
    return nullptr;
}

std::string Args::usage() const {
    std::ostringstream os;
    os << "usage: lidarflow " << command_ << " [options]\n";
    for (const auto &s : spec_) {
        std::string left = "  --" + s.name;
        if (left.size() < 22) left.resize(22, ' ');
        os << left << ' ' << s.help << '\n';
    }
    return os.str();
}

bool Args::has(const std::string &name) const {
    for (const auto &kv : values_)
        if (kv.first == name) return true;
    return false;
}

std::string Args::str(const std::string &name, const std::string &def) const {
    std::string out = def;
    for (const auto &kv : values_)  // the last occurrence wins
        if (kv.first == name) out = kv.second;
    return out;
}

std::string Args::required(const std::string &name) const {
    require(has(name), command_ + ": missing required option --" + name);
    return str(name, "");
}

int Args::integer(const std::string &name, int def) const {
    if (!has(name)) return def;
    const std::string s = str(name, "");
    errno = 0;
    char *end = nullptr;
    const long v = std::strtol(s.c_str(), &end, 10);
    require(!s.empty() && *end == '\0' && errno == 0 && v >= INT32_MIN && v <= INT32_MAX,
            command_ + ": --" + name + " expects an integer, got '" + s + "'");
    return static_cast<int>(v);
}

double Args::number(const std::string &name, double def) const {
    if (!has(name)) return def;
    const std::string s = str(name, "");
    errno = 0;
    char *end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    require(!s.empty() && *end == '\0' && errno == 0 && std::isfinite(v),
            command_ + ": --" + name + " expects a finite number, got '" + s + "'");
    return v;
}

double Args::number_in(const std::string &name, double def, double lo, double hi) const {
    const double v = number(name, def);
    if (!(v >= lo && v <= hi)) {
        std::ostringstream os;
        os << command_ << ": --" << name << " expects a number in [" << lo << ", " << hi << "], got '"
           << str(name, "") << "'";
        throw UsageError(os.str());
    }
    return v;
}

std::vector<std::string> Args::all(const std::string &name) const {
    std::vector<std::string> out;
    for (const auto &kv : values_)
        if (kv.first == name) out.push_back(kv.second);
    return out;
}

std::vector<std::string> Args::list(const std::string &name) const {
    return has(name) ? split_list(str(name, "")) : std::vector<std::string>{};
}

std::vector<std::string> split_list(const std::string &text) {
    std::vector<std::string> out;
    std::stringstream ss(text);
    for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) out.push_back(item);
    return out;
}

}  // namespace lidarflow::cli
