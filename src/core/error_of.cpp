// SPDX-License-Identifier: MIT
#include "core/error_of.hpp"

#include <exception>
#include <new>

#include <opencv2/core.hpp>

namespace lidarflow {

Error error_of_current_exception(const std::string &context) {
    try {
        throw;
    } catch (const Error &e) {
        return Error(e.code(), context + ": " + e.what());
    } catch (const std::bad_alloc &) {
        return Error(ErrorCode::OutOfMemory, context + ": out of memory");
    } catch (const cv::Exception &e) {
        // cv::Mat allocation failures arrive as cv::Exception, not std::bad_alloc.
        if (e.code == cv::Error::StsNoMem) return Error(ErrorCode::OutOfMemory, context + ": out of memory (OpenCV)");
        return Error(ErrorCode::Internal, context + ": OpenCV: " + e.what());
    } catch (const std::exception &e) {
        return Error(ErrorCode::Internal, context + ": " + e.what());
    } catch (...) {
        return Error(ErrorCode::Internal, context + ": unknown exception");
    }
}

}  // namespace lidarflow
