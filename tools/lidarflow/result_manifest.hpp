// SPDX-License-Identifier: MIT
#pragma once
// What `sequence --skip-existing` trusts: a pair's manifest, OUT/manifest/NNNNNNNNNN.txt, written
// (synced, then renamed into place) after the pair's result files:
//   lidarflow-result-manifest 1
//   settings <16 hex digits: FNV-1a of pipeline::result_settings_text>
//   file <path relative to OUT> <bytes> <16 hex digits: FNV-1a of the bytes>     (one per file)
//   ego <R row-major, t: 12 numbers>    the pair's metric ego-motion, when it had one (for poses)
// A pair is complete when its manifest has the same settings and lists every file asked for, each
// a regular file of its size and hash: a 0-byte, truncated or altered file, or results of another
// preset or option, are recomputed. One file per pair, so runs over parts of a drive (--frames)
// can share OUT at the same time.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lidarflow::cli {

// FNV-1a (64 bit) of the text: the settings line.
uint64_t settings_digest(const std::string &settings_text);

// Writes OUT/manifest/<id>.txt for `files` (paths under `out`, as result_file_paths gives them).
// Throws Error(Io) when a file cannot be read or the manifest written (no temporary file stays).
// `ego`: the pair's ego-motion [R | t] (points of the t0 camera -> the t1 camera), if any.
void write_result_manifest(const std::string &out, const std::string &id, uint64_t settings,
                           const std::vector<std::string> &files, const std::optional<cv::Matx34d> &ego);

// Whether OUT/manifest/<id>.txt exists, has `settings` and vouches for every one of `files`
// (read back and hashed), and sets `ego` to the recorded ego-motion (nullopt without one). Never
// throws for bad files: false.
bool result_manifest_matches(const std::string &out, const std::string &id, uint64_t settings,
                             const std::vector<std::string> &files, std::optional<cv::Matx34d> &ego);

}  // namespace lidarflow::cli
