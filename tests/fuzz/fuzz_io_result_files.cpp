// SPDX-License-Identifier: MIT
// The float result-file readers of `lidarflow viz` (src/io/result_formats.cpp: .pfm, .npy, .flo)
// on any file. The first input byte picks the reader (its extension), the rest is the file. Each
// reader either throws lidarflow::Error or returns a map of a layout it documents (float32 with 1
// to 3 channels; .npy also uint8 with one, the validity files) whose values fill the bytes after
// the header: never more than the file holds.
#include <cstdint>
#include <cstdlib>
#include <string>

#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "fuzz_support.hpp"
#include "io/result_formats.hpp"

namespace {

// A map's values in bytes against the file: the header takes some of it.
void check_fits(size_t values_bytes, size_t file_size) {
    if (values_bytes == 0 || values_bytes > file_size) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1) return 0;
    const int which = data[0] % 3;
    const size_t file_size = size - 1;
    // The readers are called directly, so the file's extension does not matter.
    const std::string &path = lidarflow::fuzz::write_scratch(data + 1, file_size, ".result");
    try {
        if (which == 2) {
            const lidarflow::FlowField f = lidarflow::io::read_flo(path);
            const size_t n = static_cast<size_t>(f.width()) * static_cast<size_t>(f.height());
            if (f.u.size() != f.v.size() || f.u.size() != f.valid.size() || 12 + 8 * n != file_size) std::abort();
        } else {
            const cv::Mat m = which == 0 ? lidarflow::io::read_pfm(path) : lidarflow::io::read_npy(path);
            const int c = m.channels();
            const bool npy_validity = which == 1 && m.depth() == CV_8U && c == 1;
            if (!npy_validity &&
                (m.depth() != CV_32F || (which == 0 && c != 1 && c != 3) || (which == 1 && (c < 1 || c > 3))))
                std::abort();
            check_fits(m.total() * m.elemSize(), file_size);
        }
    } catch (const lidarflow::Error &) {
    }
    return 0;
}
