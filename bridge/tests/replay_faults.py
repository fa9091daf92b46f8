# SPDX-License-Identifier: MIT
"""lidarflow-lcm-bridge --replay on bad logs and faults (CTest: bridge_replay_faults).

Every log is built here, small (three 160x64 frames), with lidarflow_lcm's writer, then broken
on purpose: event headers with impossible lengths, garbage in the middle, logs cut inside an
event, absurd log times, a calibration that changes before every frame, an output that cannot
be written, SIGINT / SIGTERM at several moments. The replay must
never crash, hang or exit 0 with frames unaccounted for; where it reads events, it reads the
same ones as lidarflow_lcm's LogReader.
"""
import io
import os
import re
import signal
import struct
import subprocess
import sys
import tempfile
import time
import unittest
import warnings

import numpy as np

import lidarflow_lcm as ll

BRIDGE = os.environ.get("LIDARFLOW_BRIDGE")
OPTIONS = ["--option", "matching.min_coarsest_height=16", "--option", "threads=1"]
W, H = 160, 64
STEREO, CALIB, LIDAR = ll.CHANNELS["stereo"], ll.CHANNELS["calibration"], ll.CHANNELS["lidar"]
HEADER = struct.Struct(">Iqqii")


def images(i):
    """Frame i: a window onto one smooth random texture, moving 2 px per frame, disparity 6."""
    n = np.random.default_rng(7).random((H + 8, W + 40))
    k = np.ones(5) / 5
    for ax in (0, 1):
        n = np.apply_along_axis(lambda r: np.convolve(r, k, "same"), ax, n)
    n = (n - n.min()) / (n.max() - n.min()) * 255
    x0 = 20 + 2 * (i % 4)
    return n[4:4 + H, x0:x0 + W].astype(np.uint8), n[4:4 + H, x0 + 6:x0 + 6 + W].astype(np.uint8)


def calibration(fx=100.0):
    return ll.calibration_message(fx, fx, W / 2, H / 2, 0.5, width=W, height=H).encode()


def stereo(i, utime=None):
    left, right = images(i)
    return ll.stereo_message(left, right, utime=1000000 + 100000 * i if utime is None else utime,
                             frame_number=i).encode()


def events_bytes(events):
    """A log of (channel, data, utime) events, as bytes."""
    buf = io.BytesIO()
    w = ll.LogWriter(buf)
    for channel, data, utime in events:
        w.write(channel, data, utime)
    return buf.getvalue()


def good_events(n=3):
    return [(CALIB, calibration(), 0)] + [(STEREO, stereo(i), 1000000 + 100000 * i) for i in range(n)]


def raw_header(number, utime, channel_len, data_len, sync=0xEDA1DA01):
    return HEADER.pack(sync, number, utime, channel_len, data_len)


@unittest.skipUnless(BRIDGE, "LIDARFLOW_BRIDGE not set (a build without LCM)")
class ReplayFaults(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.out = os.path.join(self.tmp.name, "out.log")

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, name, data):
        path = os.path.join(self.tmp.name, name)
        with open(path, "wb") as f:
            f.write(data)
        return path

    def replay(self, log, *extra, out=None, timeout=120):
        args = [BRIDGE, "--replay", log, "--out", out or self.out] + OPTIONS + list(extra)
        p = subprocess.run(args, capture_output=True, text=True, timeout=timeout)
        sys.stderr.write(p.stderr)
        self.assertGreaterEqual(p.returncode, 0, "killed by signal %d" % -p.returncode)
        return p.returncode, p.stderr

    def python_stereo_events(self, path):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ll.LogWarning)
            with ll.LogReader(path) as log:
                return sum(1 for e in log if e.channel == STEREO)

    def summary(self, err):
        m = re.search(r"events \(stereo (\d+),.*stereo processed (\d+)", err)
        self.assertIsNotNone(m, err)
        return int(m.group(1)), int(m.group(2))

    # Event headers whose data length liblcm 1.3.1 allocates unchecked (calloc(datalen + 1)).
    def test_huge_data_length_first_event(self):
        log = self.write("huge_first.log", raw_header(0, 0, len(STEREO), 0x7FFFFFFF) + STEREO.encode() + b"x" * 64)
        rc, err = self.replay(log)
        self.assertEqual(rc, 0)  # a torn tail: no whole event lost
        self.assertIn("torn tail", err)

    def test_huge_data_length_between_frames(self):
        good = events_bytes(good_events(2))
        bad = raw_header(9, 1300000, len(STEREO), 0x7FFFFFFF) + STEREO.encode()
        after = events_bytes([(STEREO, stereo(2), 1200000)])
        log = self.write("huge_mid.log", good + bad + after)
        rc, err = self.replay(log)
        self.assertEqual(rc, 3)
        self.assertRegex(err, r"LOST: log: event 9 at offset %d declares .*reading stopped" % len(good))
        self.assertEqual(self.summary(err), (2, 2))
        self.assertEqual(self.python_stereo_events(log), 2)

    # Corruption in the middle: the bridge reads the same events as the Python reader, and says
    # where it skipped or stopped (exit 3), never exit 0 with a frame unaccounted for.
    def check_corrupt(self, name, data, stereo_events):
        log = self.write(name, data)
        rc, err = self.replay(log)
        self.assertEqual(rc, 3, name)
        self.assertIn("LOST: log: ", err, name)
        self.assertEqual(self.summary(err)[0], stereo_events, name)
        self.assertEqual(self.python_stereo_events(log), stereo_events, name)

    def split(self, n=3):
        """The bytes of a good log of n frames cut after the calibration and first frame, and the rest."""
        first = events_bytes(good_events(1))
        return first, events_bytes(good_events(n))[len(first):]

    def test_garbage_after_first_frame(self):
        first, rest = self.split()
        garbage = bytes(np.random.default_rng(1).integers(0, 256, 700, dtype=np.uint8))
        assert b"\xed\xa1\xda\x01" not in garbage
        self.check_corrupt("garbage.log", first + garbage + rest, 3)

    def test_junk_before_sync_word(self):
        first, rest = self.split()
        self.check_corrupt("junk.log", first + b"junk" + rest, 3)

    def test_channel_length_zero(self):
        first, rest = self.split()
        self.check_corrupt("chan0.log", first + raw_header(5, 1100000, 0, 4) + b"abcd" + rest, 1)

    def test_channel_name_of_1000_bytes(self):
        first, rest = self.split()
        self.check_corrupt("chan1000.log", first + raw_header(5, 1100000, 1000, 0) + b"C" * 1000 + rest, 1)

    def test_data_length_100_too_long(self):
        first, rest = self.split(4)
        # The second frame claims 100 bytes of the third's header: it is malformed, reading
        # resumes inside the third (its sync word swallowed) and skips to the fourth.
        number, utime, clen, dlen = HEADER.unpack(rest[:HEADER.size])[1:]
        rest = HEADER.pack(0xEDA1DA01, number, utime, clen, dlen + 100) + rest[HEADER.size:]
        self.check_corrupt("long.log", first + rest, 3)

    # Log times far apart: status times are computed (not counted up period by period, which
    # took hours for a jump to 2^63 - 1), and the jumps are reported.
    def test_huge_log_times(self):
        events = good_events(2) + [("OTHER", b"x", 10 ** 17), ("OTHER", b"y", 2 ** 63 - 1),
                                   (STEREO, stereo(2), 2 ** 63 - 1)]
        log = self.write("times.log", events_bytes(events))
        started = time.monotonic()
        rc, err = self.replay(log, "--status-period", "0.5", "--lidar-wait-ms", "30", timeout=60)
        self.assertLess(time.monotonic() - started, 30)
        self.assertEqual(rc, 0)
        self.assertEqual(self.summary(err), (3, 3))
        self.assertEqual(len(re.findall(r"note: log time jumps by \+", err)), 2, err)
        with ll.LogReader(self.out) as out:
            status = [e for e in out if e.channel == ll.CHANNELS["status"]]
        self.assertLessEqual(len(status), 6)

    # An output that cannot be written: exit 1 at the first failed write (it used to wait for
    # the write forever, deaf to SIGINT).
    def test_full_disk(self):
        if not os.path.exists("/dev/full"):
            self.skipTest("no /dev/full")
        log = self.write("in.log", events_bytes(good_events(3)))
        rc, err = self.replay(log, out="/dev/full", timeout=60)
        self.assertEqual(rc, 1)
        self.assertRegex(err, r"cannot write /dev/full: No space left on device")
        rc, err = self.replay(log, out=os.path.join(self.tmp.name, "no", "such", "dir.log"))
        self.assertEqual(rc, 1)
        rc, err = self.replay(self.tmp.name)  # a directory is no log
        self.assertEqual(rc, 1)
        self.assertIn("not a regular file", err)

    def test_sigint_and_sigterm(self):
        log = self.write("long.log", events_bytes(good_events(300)))
        for sig in (signal.SIGINT, signal.SIGTERM):
            args = [BRIDGE, "--replay", log, "--out", self.out] + OPTIONS
            p = subprocess.Popen(args, stderr=subprocess.PIPE, text=True)
            time.sleep(1.0)
            sent = time.monotonic()
            p.send_signal(sig)
            _, err = p.communicate(timeout=30)
            self.assertLess(time.monotonic() - sent, 5, sig)
            self.assertEqual(p.returncode, 3, err)
            m = re.search(r"LOST: interrupted, (\d+) stereo frame\(s\) not replayed", err)
            self.assertIsNotNone(m, err)
            processed = self.summary(err)[1]
            dropped = int(re.search(r"stereo processed \d+, dropped (\d+)", err).group(1))  # queued at the stop
            self.assertGreater(int(m.group(1)), 0)
            self.assertEqual(processed + dropped + int(m.group(1)), 300, err)
            with ll.LogReader(self.out, strict=True) as out:  # whole events only
                self.assertGreater(sum(1 for _ in out), 0)

    # A signal at several moments: while the replay hands over a long LiDAR prelude (before the
    # first frame), and at several times into the frames (the replay then waits for the worker's
    # result of a frame: mid-frame). Each time: exit 3 within a second of the signal, every frame
    # processed, dropped at the stop or counted as not replayed, and OUT.log whole events only
    # (strict reading), its last a status.
    def interrupt(self, log, sig, after_s, frames):
        args = [BRIDGE, "--replay", log, "--out", self.out] + OPTIONS
        if os.path.exists(self.out):
            os.remove(self.out)
        p = subprocess.Popen(args, stderr=subprocess.PIPE, text=True)
        # From when OUT.log exists: the handlers are set before it is opened (earlier, the
        # process is still loading and a signal ends it the default way).
        while not os.path.exists(self.out) and p.poll() is None:
            time.sleep(0.01)
        time.sleep(after_s)
        sent = time.monotonic()
        p.send_signal(sig)
        _, err = p.communicate(timeout=30)
        took = time.monotonic() - sent
        self.assertEqual(p.returncode, 3, err)
        self.assertLess(took, 1.0, "%s %.1f s in: exit %.2f s after the signal" % (sig.name, after_s, took))
        # The count of frames left stops after 0.3 s ("at least"): a long rest of the log must
        # not hold the exit up.
        m = re.search(r"LOST: interrupted, (at least )?(\d+) stereo frame\(s\) not replayed", err)
        self.assertIsNotNone(m, err)
        sys.stderr.write("%s %.1f s in: exit %.3f s after it; %s\n" % (sig.name, after_s, took, m.group(0)))
        processed = self.summary(err)[1]
        dropped = int(re.search(r"stereo processed \d+, dropped (\d+)", err).group(1))
        if m.group(1):
            self.assertLessEqual(processed + dropped + int(m.group(2)), frames, err)
        else:
            self.assertEqual(processed + dropped + int(m.group(2)), frames, err)
        with ll.LogReader(self.out, strict=True) as out:
            events = list(out)
        self.assertEqual(events[-1].channel, ll.CHANNELS["status"])
        final = ll.status_t.decode(events[-1].data)
        self.assertEqual(final.stereo_processed, processed)
        return processed, took

    def test_signal_before_the_first_frame(self):
        sweep = ll.lidar_message(np.array([[10, 10, 6], [50, 20, 6]], np.float32), utime=0).encode()
        events = [(CALIB, calibration(), 0)] + [(LIDAR, sweep, 1 + i) for i in range(200000)]
        events += [(STEREO, stereo(i), 1000000 + 100000 * i) for i in range(3)]
        log = self.write("prelude.log", events_bytes(events))
        for sig in (signal.SIGINT, signal.SIGTERM):
            processed, _ = self.interrupt(log, sig, 0.5, 3)
            self.assertEqual(processed, 0)

    def test_signal_mid_frame(self):
        # Enough frames that the last signal still comes mid-replay (300 took 2.2 s at the
        # default preset on two cores).
        log = self.write("frames.log", events_bytes(good_events(2000)))
        seen = []
        for sig, after_s in ((signal.SIGINT, 0.4), (signal.SIGTERM, 0.9), (signal.SIGINT, 1.7), (signal.SIGTERM, 2.6)):
            seen.append(self.interrupt(log, sig, after_s, 2000))
        self.assertGreater(max(p for p, _ in seen), 0, seen)

    # Logs cut inside their last event (its header, channel name or data), as a crash of the
    # logger leaves them: the whole events before are replayed, the cut one is a note (exit 0:
    # no whole event lost), and the Python reader sees the same frames.
    def test_truncated_logs(self):
        whole = events_bytes(good_events(3))
        last = len(events_bytes(good_events(2)))
        for name, cut in (("header", last + 10), ("channel", last + HEADER.size + 3), ("data", len(whole) - 100)):
            self.assertLess(last, cut)
            log = self.write("cut_%s.log" % name, whole[:cut])
            rc, err = self.replay(log)
            self.assertEqual(rc, 0, name)
            self.assertRegex(err, r"note: log: .*(torn tail|\d+ bytes of an event header)", name)
            self.assertEqual(self.summary(err), (2, 2), name)
            self.assertEqual(self.python_stereo_events(log), 2, name)
            with ll.LogReader(self.out, strict=True) as out:
                self.assertGreater(sum(1 for e in out if e.channel == ll.CHANNELS["flow"]), 0, name)

    # An output the kernel refuses even to root: exit 1 with the reason, no output written.
    def test_unwritable_output(self):
        if not os.path.exists("/proc/version"):
            self.skipTest("no /proc")
        log = self.write("in.log", events_bytes(good_events(1)))
        rc, err = self.replay(log, out="/proc/version")
        self.assertEqual(rc, 1)
        self.assertIn("/proc/version", err)

    # A calibration that changes before every frame: no pair can be computed; each one lost is
    # counted and listed (it used to be exit 0 with 0 results and no word).
    def test_calibration_change_breaks_pairs(self):
        events = []
        for i in range(3):
            events += [(CALIB, calibration(100.0 if i % 2 == 0 else 100.5), 1000000 + 100000 * i - 1),
                       (STEREO, stereo(i), 1000000 + 100000 * i)]
        log = self.write("calib.log", events_bytes(events))
        rc, err = self.replay(log)
        self.assertEqual(rc, 3)
        self.assertEqual(self.summary(err), (3, 3))
        for frame_number in (1, 2):
            self.assertRegex(err, r"LOST: stereo frame utime \d+ \(sequence 0, frame_number %d, log event \d+\): no "
                                  r"result, the calibration changed" % frame_number)
        self.assertIn("0 results", err)
        self.assertIn("pairs lost to a calibration change 2", err)
        with ll.LogReader(self.out) as out:  # and in status_t
            status = [ll.status_t.decode(e.data) for e in out if e.channel == ll.CHANNELS["status"]]
        self.assertEqual(status[-1].pairs_lost_calibration_change, 2)

    # A flood of bad messages is not a flood of lines: 10 per kind and 10 s, then a count.
    def test_log_lines_rate_limited(self):
        events = [(CALIB, b"junk %d" % i, i) for i in range(200)] + good_events(2)
        log = self.write("flood.log", events_bytes(events))
        rc, err = self.replay(log)
        self.assertEqual(rc, 0)
        self.assertEqual(len(re.findall(r"malformed message on LIDARFLOW_CALIB", err)), 11, err)
        self.assertIn("190 more line(s) like this one not shown, the last: malformed message on LIDARFLOW_CALIB", err)
        self.assertIn("calibration malformed 200", err)

    # A frame stamped far ahead of the log's clock: the LiDAR look-ahead stops after
    # --lidar-wait-ms of log time from the event after it (it used to read the rest of the log
    # into memory, every event's log time being before the frame's), and the frame is counted.
    def test_lookahead_bounded_for_a_frame_stamped_ahead(self):
        sweep = ll.lidar_message(np.array([[10, 10, 6], [50, 20, 6]], np.float32), utime=0).encode()
        events = good_events(2) + [(STEREO, stereo(2), 10 ** 15)]
        events += [(LIDAR, sweep, 1200000 + 10000 * i) for i in range(40)]
        log = self.write("ahead.log", events_bytes(events))
        rc, err = self.replay(log, "--lidar-wait-ms", "30")
        self.assertEqual(rc, 0)
        self.assertRegex(err, r"note: stereo log event 3 \(log time 1000000000000000\): LiDAR look-ahead stopped, "
                              r"the frame's log time is ahead of the events after it")
        self.assertIn("lidar 40,", err)
        self.assertEqual(self.summary(err), (3, 3))


if __name__ == "__main__":
    unittest.main(verbosity=2)
