// SPDX-License-Identifier: MIT
#pragma once
// One mapping of any caught exception onto the core's Error, for the places that must go on
// after one unit of work failed (a pair of a stream, a frame worker) and report it by code.
#include <string>

#include "core/error.hpp"

namespace lidarflow {

// The Error that the exception being handled stands for, its message "<context>: ...":
// lidarflow::Error keeps its code; std::bad_alloc and OpenCV's StsNoMem are OutOfMemory; any
// other cv::Exception, std::exception or unknown exception is Internal. Call only inside a
// catch block (it rethrows the current exception to inspect it). Thread-safe.
Error error_of_current_exception(const std::string &context);

}  // namespace lidarflow
