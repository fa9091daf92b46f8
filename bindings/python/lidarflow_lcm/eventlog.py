# SPDX-License-Identifier: MIT
"""LCM event logs (what lcm-logger writes and lcm-logplayer plays), in pure Python.

Each event: sync word 0xEDA1DA01, int64 event number, int64 utime [us], int32 channel length,
int32 data length, the channel name, the data; all big-endian. The reader skips bytes that are
not a sync word up to the next one, stops at a header with impossible lengths, and ends a log
cut mid-write at its last whole event; each such place is a line in `problems` and a LogWarning,
or a LogFormatError with strict=True. (liblcm 1.3.1's lcm_eventlog_read_next_event instead stops
silently at garbage after an event, dropping that event too.) lidarflow-lcm-bridge --replay
reads logs by the same rules (bridge/log_reader.cpp), so both see the same events.
"""
import collections
import struct
import time
import warnings

from . import messages

__all__ = ["Event", "LogReader", "LogWriter", "LogFormatError", "LogWarning", "read_messages"]

SYNC = 0xEDA1DA01
_SYNC_BYTES = struct.pack(">I", SYNC)
_HEADER = struct.Struct(">Iqqii")
MAX_CHANNEL_BYTES = 999  # liblcm's reader refuses longer channel names (channellen >= 1000)

Event = collections.namedtuple("Event", "event_number utime channel data")
Event.__doc__ = "One log event: event_number, utime [us], channel (str), data (bytes)."


class LogFormatError(ValueError):
    """A log that is not what it should be (strict reading), or an event that cannot be written."""


class LogWarning(UserWarning):
    """Skipped garbage or a torn tail in a log read with strict=False."""


class LogReader:
    """Iterates the events of an LCM log file, in file order.

        with LogReader("out.log", channels="LIDARFLOW_FLOW") as log:
            for event in log:
                ...

    channels: None (all), a channel name, or an iterable of names: other events are skipped
    (their data is not read into memory). strict=False (default) reads past what it can and records
    each irregularity in `problems` (and warns once per log); strict=True raises LogFormatError
    at the first one instead. `path` may also be a binary file object. data=False yields the
    events with data None, never reading it (counting the frames of a long log).
    """

    def __init__(self, path, channels=None, strict=False, data=True):
        self._own = not hasattr(path, "read")
        self._f = open(path, "rb") if self._own else path
        self.name = path if self._own else getattr(path, "name", "<log>")
        if channels is None or isinstance(channels, str):
            self._channels = None if channels is None else {channels}
        else:
            self._channels = set(channels)
        self.strict = strict
        self.data = data
        self.problems = []

    def close(self):
        if self._own and not self._f.closed:
            self._f.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _problem(self, text):
        text = "%s: %s" % (self.name, text)
        if self.strict:
            raise LogFormatError(text)
        self.problems.append(text)
        warnings.warn(text, LogWarning, stacklevel=3)

    def _resync(self, start):
        """Offset of the next sync word at or after `start`, or None at the end of the file."""
        f, pos, tail = self._f, start, b""
        f.seek(start)
        while True:
            chunk = f.read(1 << 16)
            if not chunk:
                return None
            buf = tail + chunk
            i = buf.find(_SYNC_BYTES)
            if i >= 0:
                return pos - len(tail) + i
            tail = buf[-3:]
            pos += len(chunk)

    def __iter__(self):
        f = self._f
        offset = f.tell()
        while True:
            f.seek(offset)
            head = f.read(_HEADER.size)
            if not head:
                return
            if len(head) >= 4 and head[:4] != _SYNC_BYTES:
                found = self._resync(offset)
                skipped = (found if found is not None else f.seek(0, 2)) - offset
                self._problem("%d bytes without a sync word skipped at offset %d%s"
                              % (skipped, offset, "" if found is not None else " (to the end of the log)"))
                if found is None:
                    return
                offset = found
                continue
            if len(head) < _HEADER.size:
                self._problem("torn tail at offset %d: %d bytes of an event header (%d), ignored"
                              % (offset, len(head), _HEADER.size))
                return
            _, number, utime, channel_len, data_len = _HEADER.unpack(head)
            if not 0 < channel_len <= MAX_CHANNEL_BYTES or data_len < 0:
                # liblcm stops reading here too; nothing after it can be trusted (so does the bridge).
                self._problem("event at offset %d has channel length %d (1..%d) and data length %d (>= 0): "
                              "reading stops" % (offset, channel_len, MAX_CHANNEL_BYTES, data_len))
                return
            channel_raw = f.read(channel_len)
            end = offset + _HEADER.size + channel_len + data_len
            if len(channel_raw) < channel_len or f.seek(0, 2) < end:
                self._problem("torn tail at offset %d: event %d declares %d bytes, the log has %d; ignored"
                              % (offset, number, end - offset, f.tell() - offset))
                return
            channel = channel_raw.decode("utf-8", "replace")
            offset = end
            if self._channels is not None and channel not in self._channels:
                continue
            if not self.data:
                yield Event(number, utime, channel, None)
                continue
            f.seek(end - data_len)
            data = f.read(data_len)
            yield Event(number, utime, channel, data)


class LogWriter:
    """Writes an LCM log that lcm-logplayer (liblcm) plays: events numbered from 0 in write order.

        with LogWriter("in.log") as log:
            log.write_message("LIDARFLOW_CALIB", calibration_message(...), utime=0)

    mode "w" replaces an existing file, "x" refuses one. `path` may also be a binary file object.
    """

    def __init__(self, path, mode="w"):
        if mode not in ("w", "x"):
            raise ValueError("mode must be 'w' or 'x', got %r" % (mode,))
        self._own = not hasattr(path, "write")
        self._f = open(path, mode + "b") if self._own else path
        self.event_number = 0

    def write(self, channel, data, utime=None):
        """Appends one event; utime [us] defaults to now. Returns its event number."""
        raw_channel = channel.encode("utf-8")
        if not 0 < len(raw_channel) <= MAX_CHANNEL_BYTES:
            raise LogFormatError("channel name of %d bytes (liblcm reads 1..%d)" % (len(raw_channel), MAX_CHANNEL_BYTES))
        data = bytes(data)
        if len(data) > 0x7FFFFFFF:
            raise LogFormatError("event data of %d bytes (at most 2^31 - 1)" % len(data))
        if utime is None:
            utime = time.time_ns() // 1000
        number = self.event_number
        self._f.write(_HEADER.pack(SYNC, number, int(utime), len(raw_channel), len(data)) + raw_channel + data)
        self.event_number += 1
        return number

    def write_message(self, channel, msg, utime=None):
        """write() of msg.encode()."""
        return self.write(channel, msg.encode(), utime)

    def close(self):
        if self._own:
            self._f.close()
        else:
            self._f.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_messages(path, channels=None, strict=False):
    """(event, message) for every event of the log (on `channels`, see LogReader): message is
    the decoded lidarflow type chosen by its fingerprint, or None for other types (bot_core
    inputs, foreign channels). A malformed lidarflow message raises messages.MessageError
    naming the event."""
    with LogReader(path, channels=channels, strict=strict) as log:
        for event in log:
            cls = messages.type_of(event.data)
            if cls is None:
                yield event, None
                continue
            try:
                msg = cls.decode(event.data)
            except messages.MessageError as e:
                raise messages.MessageError("event %d on %s: %s" % (event.event_number, event.channel, e)) from None
            yield event, msg
