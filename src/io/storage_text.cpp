// SPDX-License-Identifier: MIT
#include "io/storage_text.hpp"

#include <fstream>

namespace lidarflow::io {

bool xml_cut_short(const std::string &head, const std::string &tail) {
    const size_t first = head.find_first_not_of(" \t\r\n");
    if (first == std::string::npos || head[first] != '<') return false;
    const size_t last = tail.find_last_not_of(" \t\r\n");
    return last == std::string::npos || tail[last] != '>';
}

bool xml_file_cut_short(const std::string &path) {
    constexpr std::streamoff kEnd = 4096;
    if (path.size() >= 3 && path.compare(path.size() - 3, 3, ".gz") == 0) return false;
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::string head(kEnd, '\0');
    in.read(&head[0], kEnd);
    head.resize(static_cast<size_t>(in.gcount()));
    in.clear();
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < 0) return false;
    const std::streamoff from = size > kEnd ? size - kEnd : 0;
    std::string tail(static_cast<size_t>(size - from), '\0');
    in.seekg(from);
    in.read(&tail[0], size - from);
    tail.resize(static_cast<size_t>(in.gcount()));
    return xml_cut_short(head, tail);
}

}  // namespace lidarflow::io
