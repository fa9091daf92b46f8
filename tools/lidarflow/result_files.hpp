// SPDX-License-Identifier: MIT
#pragma once
// Result files of `run` and `sequence`: the --format list and the files of one frame pair,
// written so that a killed run never leaves a partial file under a final name.
#include <string>
#include <vector>

#include "core/maps.hpp"
#include "io/result_formats.hpp"

namespace lidarflow::cli {

// "kitti", "flo", "pfm", "npy" without repeats, in the given order. Throws Error(InvalidArgument)
// for another name or an empty list; `command` starts the message.
std::vector<io::ResultFormat> parse_formats(const std::vector<std::string> &names, const std::string &command);

// Every file the formats write for `id` under `out` (io::result_paths), without repeats: flo and
// pfm share the disparities.
std::vector<std::string> result_file_paths(const std::string &out, const std::string &id,
                                           const std::vector<io::ResultFormat> &formats);

// Writes the field in every format and returns result_file_paths. Each file is first written
// under a temporary name in its own folder, synced to the disk and then renamed over the final
// name (the folders synced after), so a reader (or --skip-existing) never sees a partial file, not
// even after a power cut. Throws Error(Io) when a file cannot be written, synced or renamed (every
// temporary file of that call is removed, those of a format that failed halfway included),
// InvalidArgument like io::write_results.
std::vector<std::string> write_result_files(const std::string &out, const std::string &id, const SceneFlowField &f,
                                            const std::vector<io::ResultFormat> &formats);

// Writes `text` to `path` as write_result_files writes a result: a hidden temporary file in the
// same folder, synced, renamed over `path`, the folder synced. Throws Error(Io) (the temporary
// file removed).
void write_text_durably(const std::string &path, const std::string &text);

}  // namespace lidarflow::cli
