// SPDX-License-Identifier: MIT
#include "io/kitti_layout.hpp"

#include <algorithm>
#include <filesystem>

#include "core/error.hpp"

namespace lidarflow::io {

namespace {
bool is_frame_id(const std::string &id) {
    return id.size() == 6 && std::all_of(id.begin(), id.end(), [](char c) { return c >= '0' && c <= '9'; });
}
}  // namespace

void KittiLayout::check_id(const std::string &id) {
    require(is_frame_id(id), ErrorCode::InvalidArgument,
            "frame id '" + id + "' is not a KITTI frame id (6 digits, e.g. 000002)");
}

std::vector<std::string> KittiLayout::ids_in(const std::string &folder) const {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(root) / folder;
    require(fs::is_directory(dir), ErrorCode::Io, "no " + folder + "/ folder in " + root);
    std::vector<std::string> ids;
    for (const auto &e : fs::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name.size() == 13 && name.compare(6, 7, "_10.png") == 0 && is_frame_id(name.substr(0, 6)))
            ids.push_back(name.substr(0, 6));
    }
    std::sort(ids.begin(), ids.end());
    return ids;
}

}  // namespace lidarflow::io
