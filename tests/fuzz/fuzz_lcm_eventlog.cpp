// SPDX-License-Identifier: MIT
// The bridge's LCM log reader (bridge/log_reader.cpp, what --replay reads with) on any file:
// event headers, channel and data lengths, sync words, torn tails. It must end (no loop), never
// allocate more than the file holds, and return only events that lie whole inside the file, in
// file order, with a channel of 1..999 bytes and data of the declared length. Both ways of
// reading (with the data, and headers only as the replay does for channels it leaves out) give
// the same events.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "log_reader.hpp"

namespace {

struct Seen {
    int64_t offset, number, utime;
    std::string channel;
    int32_t size;
};

std::vector<Seen> read_all(const std::string &path, size_t file_size, bool with_data, size_t *problems,
                           bool *torn) {
    lidarflow::bridge::EventLogReader r;
    if (!r.open(path)) std::abort();
    std::vector<Seen> out;
    lidarflow::bridge::LogEvent e;
    int64_t last_end = -1;
    auto skip_data = [](const std::string &, void *) { return false; };
    while (with_data ? r.next(&e) : r.next(&e, skip_data, nullptr)) {
        const int64_t end = e.offset + 28 + static_cast<int64_t>(e.channel.size()) + e.data_size;
        if (e.offset < last_end || e.offset < 0 || end > static_cast<int64_t>(file_size)) std::abort();
        if (e.channel.empty() || e.channel.size() > 999 || e.data_size < 0) std::abort();
        if (with_data ? e.data.size() != static_cast<size_t>(e.data_size) : !e.data.empty()) std::abort();
        last_end = end;
        out.push_back({e.offset, e.event_number, e.utime, e.channel, e.data_size});
        if (out.size() > file_size / 29 + 1) std::abort();  // more events than fit: a loop
    }
    if (r.next(&e)) std::abort();  // the end stays the end
    *problems = r.problems().size();
    *torn = !r.torn_tail().empty();
    for (const auto &p : r.problems())
        if (p.offset < 0 || p.offset > static_cast<int64_t>(file_size) || p.text.empty()) std::abort();
    return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string &path = lidarflow::fuzz::write_scratch(data, size, ".log");
    size_t p1 = 0, p2 = 0;
    bool t1 = false, t2 = false;
    const std::vector<Seen> a = read_all(path, size, true, &p1, &t1);
    const std::vector<Seen> b = read_all(path, size, false, &p2, &t2);
    if (a.size() != b.size() || p1 != p2 || t1 != t2) std::abort();
    for (size_t i = 0; i < a.size(); ++i)
        if (a[i].offset != b[i].offset || a[i].number != b[i].number || a[i].utime != b[i].utime ||
            a[i].channel != b[i].channel || a[i].size != b[i].size)
            std::abort();
    return 0;
}
