// SPDX-License-Identifier: MIT
#include "log_reader.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cinttypes>
#include <cstring>

#include "wire.hpp"
#include "wire_detail.hpp"

namespace lidarflow::bridge {
namespace {

constexpr uint8_t kSync[4] = {0xED, 0xA1, 0xDA, 0x01};
constexpr size_t kHeaderSize = 4 + 8 + 8 + 4 + 4;
constexpr int32_t kMaxChannelBytes = 999;  // liblcm's reader refuses channellen >= 1000

uint64_t be(const uint8_t *p, int n) {
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v = v << 8 | p[i];
    return v;
}

}  // namespace

EventLogReader::~EventLogReader() {
    if (f_) std::fclose(f_);
}

bool EventLogReader::open(const std::string &path) {
    f_ = std::fopen(path.c_str(), "rb");
    if (!f_) {
        error_ = path + ": " + std::strerror(errno);
        return false;
    }
    struct stat st;
    if (fstat(fileno(f_), &st) != 0 || !S_ISREG(st.st_mode)) {
        // Every header is checked against the file's size, and skipping to a sync word seeks.
        error_ = path + ": not a regular file (a log is read with its size known; copy a pipe to a file first)";
        return false;
    }
    return true;
}

int64_t EventLogReader::file_size() {
    struct stat st;
    return fstat(fileno(f_), &st) == 0 ? static_cast<int64_t>(st.st_size) : 0;
}

bool EventLogReader::read_at(int64_t offset, void *buf, size_t n, size_t *got) {
    *got = 0;
    if (fseeko(f_, static_cast<off_t>(offset), SEEK_SET) != 0) return false;
    *got = std::fread(buf, 1, n, f_);
    return !std::ferror(f_);
}

int64_t EventLogReader::find_sync(int64_t from) {
    std::vector<uint8_t> buf(1 << 16);
    for (int64_t pos = from;;) {
        size_t got = 0;
        if (!read_at(pos, buf.data(), buf.size(), &got) || got < sizeof kSync) return -1;
        for (size_t i = 0; i + sizeof kSync <= got; ++i)
            if (std::memcmp(&buf[i], kSync, sizeof kSync) == 0) return pos + static_cast<int64_t>(i);
        if (got < buf.size()) return -1;
        pos += static_cast<int64_t>(got - (sizeof kSync - 1));  // a sync word across the chunk edge
    }
}

bool EventLogReader::next(LogEvent *event, bool (*read_data)(const std::string &, void *), void *user) {
    while (f_ && !done_) {
        uint8_t head[kHeaderSize];
        size_t got = 0;
        if (!read_at(offset_, head, sizeof head, &got)) {
            problems_.push_back({offset_, printf_string("read error at offset %" PRId64 ": %s", offset_,
                                                        std::strerror(errno)), true});
            break;
        }
        if (got == 0) break;
        if (got >= sizeof kSync && std::memcmp(head, kSync, sizeof kSync) != 0) {
            const int64_t found = find_sync(offset_);
            if (found < 0) {
                torn_tail_ = printf_string("%" PRId64 " bytes without a sync word at offset %" PRId64
                                           " to the end of the log, ignored", file_size() - offset_, offset_);
                break;
            }
            problems_.push_back({offset_, printf_string("%" PRId64 " bytes without a sync word skipped at offset %"
                                                        PRId64 " (events there, if any, not read)",
                                                        found - offset_, offset_), false});
            offset_ = found;
            continue;
        }
        if (got < sizeof head) {
            torn_tail_ = printf_string("%zu bytes of an event header at offset %" PRId64 " (%zu), ignored", got,
                                       offset_, sizeof head);
            break;
        }
        const auto number = static_cast<int64_t>(be(head + 4, 8));
        const auto utime = static_cast<int64_t>(be(head + 12, 8));
        const auto channel_len = static_cast<int32_t>(be(head + 20, 4));
        const auto data_len = static_cast<int32_t>(be(head + 24, 4));
        const int64_t size = file_size();
        if (channel_len < 1 || channel_len > kMaxChannelBytes || data_len < 0) {
            problems_.push_back({offset_, printf_string("event at offset %" PRId64 " has channel length %d (1..%d) "
                                                        "and data length %d (>= 0): reading stopped there, %" PRId64
                                                        " bytes not read", offset_, channel_len, kMaxChannelBytes,
                                                        data_len, size - offset_), true});
            break;
        }
        const int64_t end = offset_ + static_cast<int64_t>(kHeaderSize) + channel_len + data_len;
        if (end > size) {
            const std::string what = printf_string("event %" PRId64 " at offset %" PRId64 " declares %" PRId64
                                                   " bytes, the log has %" PRId64, number, offset_, end - offset_,
                                                   size - offset_);
            // A sync word after this header: not the cut-short last write but corruption with
            // events behind it (which the Python reader, too, does not read).
            if (find_sync(offset_ + static_cast<int64_t>(sizeof kSync)) >= 0)
                problems_.push_back({offset_, what + ": reading stopped there, the rest not read", true});
            else
                torn_tail_ = what + " (a torn tail), ignored";
            break;
        }
        std::string channel(static_cast<size_t>(channel_len), '\0');
        if (!read_at(offset_ + static_cast<int64_t>(kHeaderSize), &channel[0], channel.size(), &got) ||
            got != channel.size()) {
            problems_.push_back({offset_, printf_string("read error at offset %" PRId64, offset_), true});
            break;
        }
        event->event_number = number;
        event->utime = utime;
        event->offset = offset_;
        event->data_size = data_len;
        event->data.clear();
        if (!read_data || read_data(channel, user)) {
            event->data.resize(static_cast<size_t>(data_len));
            if (data_len > 0 && (std::fread(event->data.data(), 1, event->data.size(), f_) != event->data.size())) {
                problems_.push_back({offset_, printf_string("read error at offset %" PRId64, offset_), true});
                break;
            }
        }
        event->channel = std::move(channel);
        offset_ = end;
        return true;
    }
    done_ = true;
    return false;
}

EventLogWriter::~EventLogWriter() {
    if (f_) std::fclose(f_);
}

bool EventLogWriter::open(const std::string &path) {
    f_ = std::fopen(path.c_str(), "wb");
    if (!f_) error_ = path + ": " + std::strerror(errno);
    return f_ != nullptr;
}

bool EventLogWriter::write(int64_t utime, const std::string &channel, const void *data, size_t size) {
    if (!f_ || !error_.empty()) return false;
    if (channel.empty() || channel.size() > static_cast<size_t>(kMaxChannelBytes) || size > 0x7FFFFFFFu) {
        error_ = "an event that an LCM log cannot hold (channel or data too long)";
        return false;
    }
    uint8_t head[kHeaderSize];
    std::memcpy(head, kSync, sizeof kSync);
    detail::write_be(head + 4, static_cast<uint64_t>(next_number_), 8);
    detail::write_be(head + 12, static_cast<uint64_t>(utime), 8);
    detail::write_be(head + 20, channel.size(), 4);
    detail::write_be(head + 24, size, 4);
    errno = 0;
    if (std::fwrite(head, 1, sizeof head, f_) != sizeof head ||
        std::fwrite(channel.data(), 1, channel.size(), f_) != channel.size() ||
        (size && std::fwrite(data, 1, size, f_) != size) || std::fflush(f_) != 0) {
        error_ = errno ? std::strerror(errno) : "write failed";
        return false;
    }
    ++next_number_;
    return true;
}

bool EventLogWriter::close() {
    if (!f_) return error_.empty();
    const int rc = std::fclose(f_);
    f_ = nullptr;
    if (rc != 0 && error_.empty()) error_ = std::strerror(errno);
    return error_.empty();
}

}  // namespace lidarflow::bridge
