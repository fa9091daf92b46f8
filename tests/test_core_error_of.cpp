// SPDX-License-Identifier: MIT
// core/error_of.hpp: every exception a unit of work can end with maps onto the core's Error,
// with its code and the context first in the message.
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "core/error_of.hpp"
#include "test_support.hpp"

using namespace lidarflow;

namespace {

template <class Throw>
Error mapped(Throw &&t) {
    try {
        t();
    } catch (...) {
        return error_of_current_exception("pair 4->5");
    }
    fail_msg("nothing was thrown");
    return Error(ErrorCode::Internal, "");
}

bool starts_with(const char *s, const std::string &prefix) { return std::strncmp(s, prefix.c_str(), prefix.size()) == 0; }

void each_kind_keeps_its_code(void **) {
    Error e = mapped([] { throw Error(ErrorCode::SizeMismatch, "images differ"); });
    assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::SizeMismatch));
    assert_string_equal(e.what(), "pair 4->5: images differ");

    e = mapped([] { throw std::bad_alloc(); });
    assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::OutOfMemory));
    assert_string_equal(e.what(), "pair 4->5: out of memory");

    // cv::Mat's allocation failure is a cv::Exception with StsNoMem: out of memory too.
    e = mapped([] { throw cv::Exception(cv::Error::StsNoMem, "Failed to allocate", "f", "file", 1); });
    assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::OutOfMemory));
    assert_string_equal(e.what(), "pair 4->5: out of memory (OpenCV)");

    e = mapped([] { CV_Assert(1 + 1 == 3); });
    assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::Internal));
    assert_true(starts_with(e.what(), "pair 4->5: OpenCV: "));

    e = mapped([] { throw std::out_of_range("index 9"); });
    assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::Internal));
    assert_string_equal(e.what(), "pair 4->5: index 9");

    e = mapped([] { throw 42; });
    assert_int_equal(static_cast<int>(e.code()), static_cast<int>(ErrorCode::Internal));
    assert_string_equal(e.what(), "pair 4->5: unknown exception");
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {cmocka_unit_test(each_kind_keeps_its_code)};
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
