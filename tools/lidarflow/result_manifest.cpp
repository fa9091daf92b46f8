// SPDX-License-Identifier: MIT
#include "result_manifest.hpp"

#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>

#include "core/error.hpp"
#include "core/regular_file.hpp"
#include "io/read_file.hpp"
#include "result_files.hpp"

namespace lidarflow::cli {
namespace {

namespace fs = std::filesystem;

constexpr const char *kHeader = "lidarflow-result-manifest 1";
constexpr uint64_t kMaxManifestBytes = 1 << 16;

constexpr uint64_t kFnvBasis = 14695981039346656037ull, kFnvPrime = 1099511628211ull;

void fnv(uint64_t &h, const char *data, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        h ^= static_cast<unsigned char>(data[i]);
        h *= kFnvPrime;
    }
}

struct Digest {
    uint64_t bytes = 0, hash = kFnvBasis;
};

// Size and hash of a regular file, read in blocks; false when it is not one or cannot be read.
bool digest_file(const std::string &path, Digest &d) {
    RegularFile f(path);
    if (!f.ok()) return false;
    char buf[1 << 16];
    for (;;) {
        const ssize_t n = ::read(f.fd(), buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return false;
        if (n == 0) return true;
        fnv(d.hash, buf, static_cast<size_t>(n));
        d.bytes += static_cast<uint64_t>(n);
    }
}

std::string hex(uint64_t v) {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016" PRIx64, v);
    return buf;
}

std::string manifest_path(const std::string &out, const std::string &id) {
    return (fs::path(out) / "manifest" / (id + ".txt")).string();
}

// `path` relative to `out` (result_file_paths puts `out` + "/" in front).
std::string relative(const std::string &out, const std::string &path) {
    const std::string prefix = out + "/";
    return path.compare(0, prefix.size(), prefix) == 0 ? path.substr(prefix.size()) : path;
}

}  // namespace

uint64_t settings_digest(const std::string &settings_text) {
    uint64_t h = kFnvBasis;
    fnv(h, settings_text.data(), settings_text.size());
    return h;
}

void write_result_manifest(const std::string &out, const std::string &id, uint64_t settings,
                           const std::vector<std::string> &files, const std::optional<cv::Matx34d> &ego) {
    std::string text = std::string(kHeader) + "\nsettings " + hex(settings) + "\n";
    for (const std::string &p : files) {
        Digest d;
        require(digest_file(p, d), ErrorCode::Io, "cannot read back " + p);
        text += "file " + relative(out, p) + " " + std::to_string(d.bytes) + " " + hex(d.hash) + "\n";
    }
    if (ego) {
        text += "ego";
        char buf[32];
        for (double v : ego->val) {
            std::snprintf(buf, sizeof buf, " %.17g", v);  // round-trips the double
            text += buf;
        }
        text += "\n";
    }
    const fs::path dir = fs::path(out) / "manifest";
    std::error_code ec;
    fs::create_directories(dir, ec);
    require(!ec, ErrorCode::Io, "cannot create " + dir.string() + ": " + ec.message());
    write_text_durably(manifest_path(out, id), text);
}

bool result_manifest_matches(const std::string &out, const std::string &id, uint64_t settings,
                             const std::vector<std::string> &files, std::optional<cv::Matx34d> &ego) {
    ego.reset();
    std::string text;
    try {
        text = io::read_file(manifest_path(out, id), kMaxManifestBytes);
    } catch (const Error &) {
        return false;
    }
    std::istringstream in(text);
    std::string line;
    if (!std::getline(in, line) || line != kHeader) return false;
    if (!std::getline(in, line) || line != "settings " + hex(settings)) return false;
    std::map<std::string, std::string> listed;  // relative path -> "bytes hash"
    while (std::getline(in, line)) {
        std::istringstream fields(line);
        std::string tag, path, bytes, hash, extra;
        if (line.rfind("ego ", 0) == 0) {
            cv::Matx34d m;
            fields >> tag;
            for (double &v : m.val)
                if (!(fields >> v) || !std::isfinite(v)) return false;
            if (fields >> extra) return false;
            ego = m;
            continue;
        }
        if (!(fields >> tag >> path >> bytes >> hash) || tag != "file" || (fields >> extra)) return false;
        listed[path] = bytes + " " + hash;
    }
    for (const std::string &p : files) {
        const auto it = listed.find(relative(out, p));
        Digest d;
        if (it == listed.end() || !digest_file(p, d) || it->second != std::to_string(d.bytes) + " " + hex(d.hash))
            return false;
    }
    return true;
}

}  // namespace lidarflow::cli
