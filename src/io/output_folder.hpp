// SPDX-License-Identifier: MIT
#pragma once
// The output folder of a command, checked before the work that fills it: an unwritable folder
// must not be found only after minutes of estimation.
#include <string>

namespace lidarflow::io {

// Creates `dir` (with missing parents) and proves it writable by creating and removing a file
// in it. Throws Error(InvalidArgument) for an empty path, Error(Io) naming the folder and the
// reason (a path through a regular file, no permission, a read-only file system, ...).
void prepare_output_folder(const std::string &dir);

}  // namespace lidarflow::io
