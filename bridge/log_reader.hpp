// SPDX-License-Identifier: MIT
#pragma once
// LCM event logs read and written without liblcm's eventlog code, which trusts every header it
// reads: liblcm 1.3.1 allocates a header's data length + 1 bytes unchecked (0x7FFFFFFF wraps the
// int and crashes) and stops at the first bad header, dropping the event before it.
//
// The format: per event the sync word 0xEDA1DA01, int64 event number, int64 log time [us],
// int32 channel length, int32 data length, the channel name, the data; big-endian. The reader
// follows bindings/python/lidarflow_lcm/eventlog.py (LogReader) rule for rule, so both read the
// same events from any file:
//  * bytes that do not start with a sync word are skipped up to the next one (a problem);
//  * a header with a channel length outside 1..999 or a negative data length stops reading (a
//    problem: nothing after it can be trusted);
//  * an event that does not fit in the file ends reading: a torn tail when no sync word follows
//    its header (the last write was cut short), else a problem (corruption, events may follow);
//  * a partial header at the end is a torn tail.
// No header is trusted before it is checked against the file's size, so no length field makes
// the reader allocate more than the file holds.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace lidarflow::bridge {

struct LogEvent {
    int64_t event_number = 0;
    int64_t utime = 0;
    int64_t offset = 0;  // of its sync word in the file
    std::string channel;
    std::vector<uint8_t> data;  // empty when the reader was told to leave the data out
    int32_t data_size = 0;      // as in the header (also when the data was left out)
};

class EventLogReader {
public:
    EventLogReader() = default;
    ~EventLogReader();
    EventLogReader(const EventLogReader &) = delete;
    EventLogReader &operator=(const EventLogReader &) = delete;

    // false (and error()) when the file cannot be opened.
    bool open(const std::string &path);
    // The next event; false at the end (see problems() / torn_tail()). read_data(channel) decides
    // whether the event's data is read (nullptr: always).
    bool next(LogEvent *event, bool (*read_data)(const std::string &channel, void *) = nullptr, void *user = nullptr);

    struct Problem {
        int64_t offset;
        std::string text;
        bool stopped;  // reading stopped there (the rest of the file was not read)
    };
    // Irregularities that may have cost events: skipped bytes before a sync word, a header that
    // stopped reading, an event past the end with events after it. Each once, in file order.
    const std::vector<Problem> &problems() const { return problems_; }
    // A cut-short last event or header, or bytes without a sync word up to the end ("" if none):
    // what a log whose writer was killed ends with; no whole event is lost there.
    const std::string &torn_tail() const { return torn_tail_; }
    const std::string &error() const { return error_; }
    int64_t offset() const { return offset_; }

private:
    int64_t file_size();
    int64_t find_sync(int64_t from);  // offset of the next sync word at or after `from`, or -1
    bool read_at(int64_t offset, void *buf, size_t n, size_t *got);

    std::FILE *f_ = nullptr;
    int64_t offset_ = 0;
    bool done_ = false;
    std::vector<Problem> problems_;
    std::string torn_tail_, error_;
};

// Writes an LCM log (events numbered from 0), every event flushed to the file before write()
// returns, so that a full disk or a write error is seen at once, not at close.
class EventLogWriter {
public:
    EventLogWriter() = default;
    ~EventLogWriter();
    EventLogWriter(const EventLogWriter &) = delete;
    EventLogWriter &operator=(const EventLogWriter &) = delete;
    bool open(const std::string &path);  // created or truncated
    bool write(int64_t utime, const std::string &channel, const void *data, size_t size);
    bool close();                        // false when closing failed (or a write did)
    const std::string &error() const { return error_; }

private:
    std::FILE *f_ = nullptr;
    int64_t next_number_ = 0;
    std::string error_;
};

}  // namespace lidarflow::bridge
