// SPDX-License-Identifier: MIT
#pragma once
// Texts handed to OpenCV's FileStorage parsers, checked first where those parsers crash.
#include <string>

namespace lidarflow::io {

// OpenCV 4.6's XML parser dereferences a null pointer when a tag's attribute has its '=' and then
// only white space up to the end of the text. A whole XML text ends with '>', so a text whose
// start `head` (after white space) opens a tag and whose end `tail` does not close one is cut
// short; false for anything else (YAML, or a text that ends with '>').
bool xml_cut_short(const std::string &head, const std::string &tail);

// The same for a file (its first and last 4 KiB); false when it cannot be read or is compressed
// (".gz", which OpenCV inflates itself).
bool xml_file_cut_short(const std::string &path);

}  // namespace lidarflow::io
