# SPDX-License-Identifier: MIT
"""lidarflow_lcm's LCM log reader and writer (CTest: python_lcm): round trips, channel
filters, torn tails and garbage, and logs written here played by liblcm's lcm-logplayer."""
import io
import os
import shutil
import struct
import subprocess
import tempfile
import unittest
import warnings

import numpy as np

import lidarflow_lcm as ll
from lidarflow_lcm import eventlog


def sample_events(n=6, seed=0):
    rng = np.random.default_rng(seed)
    channels = ["A", "LIDARFLOW_FLOW", "b/c.d"]
    return [(channels[i % 3], rng.bytes(int(rng.integers(0, 300))), int(rng.integers(0, 2**62))) for i in range(n)]


def write_log(events):
    buf = io.BytesIO()
    w = ll.LogWriter(buf)
    for channel, data, utime in events:
        w.write(channel, data, utime)
    w.close()
    return buf.getvalue()


class RoundTrip(unittest.TestCase):
    def test_events_come_back(self):
        events = sample_events()
        raw = write_log(events)
        got = list(ll.LogReader(io.BytesIO(raw)))
        self.assertEqual([(e.channel, e.data, e.utime) for e in got], events)
        self.assertEqual([e.event_number for e in got], list(range(len(events))))

    def test_layout_is_lcms(self):
        raw = write_log([("CH", b"xyz", 0x0102030405060708)])
        self.assertEqual(raw, struct.pack(">Iqqii", 0xEDA1DA01, 0, 0x0102030405060708, 2, 3) + b"CHxyz")

    def test_channel_filter(self):
        events = sample_events(9)
        raw = write_log(events)
        got = list(ll.LogReader(io.BytesIO(raw), channels="LIDARFLOW_FLOW"))
        self.assertEqual([e.data for e in got], [d for c, d, _ in events if c == "LIDARFLOW_FLOW"])
        self.assertEqual([e.event_number for e in got], [1, 4, 7])
        got = list(ll.LogReader(io.BytesIO(raw), channels=["A", "b/c.d"]))
        self.assertEqual(len(got), 6)

    def test_writer_refuses_what_liblcm_cannot_read(self):
        w = ll.LogWriter(io.BytesIO())
        for channel in ("", "x" * 1000):
            with self.assertRaises(ll.LogFormatError):
                w.write(channel, b"")
        self.assertEqual(w.write("x" * 999, b""), 0)

    def test_files_and_modes(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "a.log")
            with ll.LogWriter(path) as w:
                w.write_message("LIDARFLOW_CALIB", ll.calibration_message(1, 2, 3, 4, 0.5), utime=9)
            with self.assertRaises(FileExistsError):
                ll.LogWriter(path, mode="x")
            (event, msg), = ll.read_messages(path)
            self.assertEqual((event.utime, msg.fx, msg.baseline), (9, 1.0, 0.5))


class Damaged(unittest.TestCase):
    def setUp(self):
        self.events = sample_events(5, seed=1)
        self.raw = write_log(self.events)
        self.last = self.raw.rfind(struct.pack(">I", eventlog.SYNC))

    def read(self, raw, strict=False):
        r = ll.LogReader(io.BytesIO(raw), strict=strict)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got = list(r)
        return got, r.problems, caught

    def test_every_torn_tail(self):
        # A log cut anywhere inside its last event: the others read, the tail reported.
        for cut in range(self.last + 1, len(self.raw)):
            got, problems, caught = self.read(self.raw[:cut])
            self.assertEqual([e.data for e in got], [d for _, d, _ in self.events[:-1]], cut)
            self.assertEqual(len(problems), 1, cut)
            self.assertRegex(problems[0], "torn tail at offset %d" % self.last)
            self.assertEqual([str(w.message) for w in caught], problems)
            self.assertTrue(all(w.category is ll.LogWarning for w in caught))
            with self.assertRaisesRegex(ll.LogFormatError, "torn tail at offset %d" % self.last):
                self.read(self.raw[:cut], strict=True)
        got, problems, _ = self.read(self.raw)
        self.assertEqual((len(got), problems), (5, []))

    def test_garbage_between_events_is_skipped(self):
        raw = self.raw[:self.last] + b"\x01garbage\xed\xa1" + self.raw[self.last:]
        got, problems, _ = self.read(raw)
        self.assertEqual(len(got), 5)
        self.assertEqual(problems, ["<log>: 10 bytes without a sync word skipped at offset %d" % self.last])
        with self.assertRaisesRegex(ll.LogFormatError, "without a sync word"):
            self.read(raw, strict=True)
        got, problems, _ = self.read(self.raw + b"trailing junk")
        self.assertEqual((len(got), len(problems)), (5, 1))
        self.assertRegex(problems[0], "to the end of the log")

    def test_impossible_lengths_stop_reading(self):
        for channel_len, data_len in ((0, 5), (1000, 5), (3, -1)):
            bad = struct.pack(">Iqqii", eventlog.SYNC, 9, 0, channel_len, data_len) + b"abc" + b"\0" * 10
            got, problems, _ = self.read(self.raw[:self.last] + bad + self.raw[self.last:])
            self.assertEqual(len(got), 4)
            self.assertRegex(problems[0], "channel length %d .* data length %d" % (channel_len, data_len))

    def test_read_messages_names_the_malformed_event(self):
        good = ll.calibration_message(1, 1, 0, 0, 1).encode()
        raw = write_log([("C", good, 1), ("C", good[:-1], 2), ("X", b"other type", 3)])
        it = ll.read_messages(io.BytesIO(raw))
        self.assertIsInstance(next(it)[1], ll.calibration_t)
        with self.assertRaisesRegex(ll.MessageError, "event 1 on C: truncated"):
            next(it)
        got = list(ll.read_messages(io.BytesIO(raw), channels="X"))
        self.assertEqual([(e.data, m) for e, m in got], [(b"other type", None)])


@unittest.skipUnless(shutil.which("lcm-logplayer"), "lcm-logplayer not installed (apt-get install liblcm-bin)")
class PlayedByLiblcm(unittest.TestCase):
    def test_logplayer_plays_a_python_log(self):
        # lcm-logplayer (liblcm's reader) publishes every event of our log into a file:// LCM,
        # which liblcm's writer records; our reader then finds the same channels and data.
        events = sample_events(12, seed=2)
        events.append(("LIDARFLOW_STATUS", ll.status_t(stereo_received=3, last_error="x").encode(), 10**15))
        events = [(c, d, 1000 + 1000 * i) for i, (c, d, _) in enumerate(events)]
        with tempfile.TemporaryDirectory() as tmp:
            src, played = os.path.join(tmp, "py.log"), os.path.join(tmp, "played.log")
            with ll.LogWriter(src) as w:
                for channel, data, utime in events:
                    w.write(channel, data, utime)
            subprocess.run(["lcm-logplayer", "-s", "100", "-l", "file://%s?mode=w" % played, src], check=True,
                           timeout=60, capture_output=True)
            with ll.LogReader(played, strict=True) as log:
                got = list(log)
        self.assertEqual([(e.channel, e.data) for e in got], [(c, d) for c, d, _ in events])
        self.assertEqual(ll.status_t.decode(got[-1].data).stereo_received, 3)


if __name__ == "__main__":
    unittest.main()
