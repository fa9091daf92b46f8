// SPDX-License-Identifier: MIT
#include "result_files.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "core/error.hpp"

namespace lidarflow::cli {

std::vector<io::ResultFormat> parse_formats(const std::vector<std::string> &names, const std::string &command) {
    std::vector<io::ResultFormat> out;
    for (const std::string &n : names) {
        const io::ResultFormat f = io::parse_result_format(n);
        if (std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
    }
    require(!out.empty(), ErrorCode::InvalidArgument, command + ": --format needs at least one of kitti, flo, pfm, npy");
    return out;
}

std::vector<std::string> result_file_paths(const std::string &out, const std::string &id,
                                           const std::vector<io::ResultFormat> &formats) {
    std::vector<std::string> paths;
    for (io::ResultFormat fmt : formats)
        for (const std::string &p : io::result_paths(out, id, fmt))
            if (std::find(paths.begin(), paths.end(), p) == paths.end()) paths.push_back(p);
    return paths;
}

namespace {

// Flushes a written file or folder to the disk: a rename is durable only after its file's data
// and, for the new name, its folder.
void sync_path(const std::string &path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    require(fd >= 0, ErrorCode::Io, [&] { return "cannot open " + path + " to sync it: " + std::strerror(errno); });
    const bool ok = ::fsync(fd) == 0 || errno == EINVAL;  // EINVAL: a file system without fsync
    const int err = errno;
    ::close(fd);
    require(ok, ErrorCode::Io, [&] { return "cannot sync " + path + ": " + std::strerror(err); });
}

// Dot-prefixed and with the process id: hidden from `ls`, and two processes writing the same
// file never share a temporary one.
std::string temporary_name(const std::string &name) {
    return ".tmp-" + std::to_string(static_cast<long>(getpid())) + "-" + name;
}

}  // namespace

void write_text_durably(const std::string &path, const std::string &text) {
    namespace fs = std::filesystem;
    const fs::path target(path);
    const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    const std::string tmp = (folder / temporary_name(target.filename().string())).string();
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    require(fd >= 0, ErrorCode::Io, [&] { return "cannot write " + tmp + ": " + std::strerror(errno); });
    const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()) &&
                         (::fsync(fd) == 0 || errno == EINVAL);
    const bool closed = ::close(fd) == 0;
    if (!written || !closed || std::rename(tmp.c_str(), path.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        std::remove(tmp.c_str());
        throw Error(ErrorCode::Io, "cannot write " + path + ": " + why);
    }
    sync_path(folder.string());
}

std::vector<std::string> write_result_files(const std::string &out, const std::string &id, const SceneFlowField &f,
                                            const std::vector<io::ResultFormat> &formats) {
    namespace fs = std::filesystem;
    io::check_output_name(id);
    const std::string tmp_id = temporary_name(id.substr(0, 100));
    std::vector<std::string> temporaries;
    const auto remove_temporaries = [&] {
        std::error_code ignored;
        for (const std::string &t : temporaries) fs::remove(t, ignored);
    };
    try {
        std::vector<std::pair<std::string, std::string>> renames;  // temporary -> final
        for (io::ResultFormat fmt : formats) {
            const std::vector<std::string> finals = io::result_paths(out, id, fmt);
            // Known before writing: a format that fails halfway leaves its first files behind.
            const std::vector<std::string> written = io::result_paths(out, tmp_id, fmt);
            temporaries.insert(temporaries.end(), written.begin(), written.end());
            io::write_results(out, tmp_id, f, fmt);
            for (size_t i = 0; i < written.size(); ++i) renames.emplace_back(written[i], finals[i]);
        }
        std::vector<std::string> folders;
        for (const auto &[from, to] : renames) {
            if (!fs::exists(from)) continue;  // flo and pfm write the same disparity twice: renamed once
            sync_path(from);
            const std::string folder = fs::path(to).parent_path().string();
            if (std::find(folders.begin(), folders.end(), folder) == folders.end()) folders.push_back(folder);
        }
        for (const auto &[from, to] : renames) {
            std::error_code ec;
            if (!fs::exists(from)) continue;
            fs::rename(from, to, ec);
            require(!ec, ErrorCode::Io, "cannot rename " + from + " to " + to + ": " + ec.message());
        }
        for (const std::string &folder : folders) sync_path(folder);
    } catch (...) {
        remove_temporaries();
        throw;
    }
    return result_file_paths(out, id, formats);
}

}  // namespace lidarflow::cli
