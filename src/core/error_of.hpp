// SPDX-License-Identifier: MIT
#pragma once
// One mapping of any caught exception onto the core's Error: the C ABI's firewall (guarded()),
// its frame workers, and `sequence`, which goes on after a pair failed.
#include <string>

#include "core/error.hpp"

namespace lidarflow {

// The Error that the exception being handled stands for, its message "<context>: ...":
// lidarflow::Error keeps its code; std::bad_alloc and OpenCV's StsNoMem are OutOfMemory; any
// other cv::Exception, std::exception or unknown exception is Internal. Call only inside a
// catch block (it rethrows the current exception to inspect it). Thread-safe.
Error error_of_current_exception(const std::string &context);

}  // namespace lidarflow
