# SPDX-License-Identifier: MIT
"""What the lidarflow_dask tests share: a small synthetic drive and LCM log, their serial run
(the reference), built once per test process at first use, and helpers."""
import atexit
import filecmp
import os
import subprocess
import sys
import tempfile
import unittest

import lidarflow_lcm as ll

BIN = os.environ.get("LIDARFLOW_BIN_DIR")
PY = sys.executable
CHUNK = 4
try:
    import distributed
except ImportError:  # reported as skipped: tools/dev.sh deps installs python3-distributed
    distributed = None

if BIN:
    import lidarflow_dask as ld
    from lidarflow_dask import results as ldr

SKIP = "LIDARFLOW_BIN_DIR not set or python3-distributed missing"
READY = bool(BIN and distributed)


def tool(*parts):
    return os.path.join(BIN, *parts)


def lidarflow(*args):
    return subprocess.run([tool("tools", "lidarflow", "lidarflow")] + list(args), check=True, capture_output=True)


def make_log(tmp):
    """8 frames of 4 synthetic scenes as one stream (one sequence, frame numbers 0..7): 7 pairs,
    three of them across a chunk boundary (frames 3 and 6 are shared by two chunks)."""
    scene, raw, log = os.path.join(tmp, "scene"), os.path.join(tmp, "raw.log"), os.path.join(tmp, "run.log")
    lidarflow("synth", "--out", scene, "--width", "320", "--height", "96", "--frames", "4")
    lidarflow("publish-kitti", "--root", scene, "--lidar", "paper", "--rate", "0", "--lcm-url", "file://%s?mode=w" % raw)
    n = 0
    with ll.LogWriter(log) as w:
        for e, m in ll.read_messages(raw, strict=True):
            if isinstance(m, ll.stereo_t):
                m.sequence, m.frame_number, n = 0, n, n + 1
                w.write(e.channel, m.encode(), e.utime)
            elif not (isinstance(m, ll.calibration_t) and n > 0):  # one calibration: one stream
                w.write(e.channel, e.data, e.utime)
    return log


def flows(path):
    """(log time, scene_flow_t bytes with compute_seconds zeroed) of a result log."""
    out = []
    for e, m in ll.read_messages(path, channels=ldr.FLOW_CHANNEL, strict=True):
        m.compute_seconds = 0.0
        out.append((e.utime, m.encode()))
    return out


def egos(path):
    """(log time, ego_motion_t bytes) of a result log."""
    with ll.LogReader(path, channels=ldr.EGO_CHANNEL, strict=True) as r:
        return [(e.utime, e.data) for e in r]


def same_tree(test, a, b):
    """Every file of folders a and b, byte for byte; returns the number of files."""
    n = 0
    for root, _, files in os.walk(a):
        rel = os.path.relpath(root, a)
        other = sorted(f for f in os.listdir(os.path.join(b, rel)) if os.path.isfile(os.path.join(b, rel, f)))
        test.assertEqual(sorted(files), other, rel)
        for f in files:
            test.assertTrue(filecmp.cmp(os.path.join(root, f), os.path.join(b, rel, f), shallow=False),
                            os.path.join(rel, f))
            n += 1
    return n


def cli(*args, env=None, timeout=300):
    return subprocess.run([PY, "-m", "lidarflow_dask"] + list(args), capture_output=True, text=True, timeout=timeout,
                          env=env)


def serial_args(out, *sources):
    """The serial command line of the reference run, into out."""
    return ["--serial", "--out", out, "--preset", "realtime", "--chunk", str(CHUNK), "--threads-per-task", "1",
            "--bin-dir", BIN] + list(sources)


class Fixture:
    """tmp (a folder), drive (9 frames: 8 pairs), log (8 frames: 7 pairs), serial (their serial
    run's OUT, chunks of 4), serial_rc/serial_summary, whole/whole_ego (the whole log's replay)."""

    def __init__(self):
        self._tmp = tempfile.TemporaryDirectory()
        atexit.register(self._tmp.cleanup)
        self.tmp = t = self._tmp.name
        self.drive = os.path.join(t, "drive")
        lidarflow("synth", "--drive", self.drive, "--frames", "9", "--width", "320", "--height", "96")
        self.log = make_log(t)
        self.settings = dict(preset="realtime", chunk=CHUNK, threads=1)
        self.serial = os.path.join(t, "serial")
        self.serial_rc, self.serial_summary = ld.run([self.drive, self.log], ld.Settings(self.serial, **self.settings))
        whole = os.path.join(t, "whole.log")
        subprocess.run([tool("bridge", "lidarflow-lcm-bridge"), "--replay", self.log, "--out", whole,
                        "--option", "preset=realtime", "--option", "threads=1"], check=True, capture_output=True)
        self.whole = flows(whole)
        self.whole_ego = egos(whole)

    def folder(self, name):
        """A new folder under tmp."""
        return tempfile.mkdtemp(prefix=name + "-", dir=self.tmp)


_fixture = None


def fixture():
    global _fixture
    if _fixture is None:
        _fixture = Fixture()
    return _fixture


@unittest.skipUnless(READY, SKIP)
class FixtureCase(unittest.TestCase):
    """Tests on the shared fixture (cls.f), skipped without the executables or Dask."""

    @classmethod
    def setUpClass(cls):
        cls.f = fixture()


def fake_bin(folder, frames_command):
    """A bin folder whose `lidarflow` runs frames_command (sh) for chunk commands (those with
    --frames) and the real CLI otherwise; the real bridge beside it."""
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "lidarflow")
    with open(path, "w") as f:
        f.write('#!/bin/sh\ncase "$*" in *--frames*) %s;; esac\nexec %s "$@"\n'
                % (frames_command, tool("tools", "lidarflow", "lidarflow")))
    os.chmod(path, 0o755)
    os.symlink(tool("bridge", "lidarflow-lcm-bridge"), os.path.join(folder, "lidarflow-lcm-bridge"))
    return folder


def processes():
    """(pid, parent pid, command name) of every process."""
    out = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open("/proc/%s/stat" % d) as f:
                stat = f.read()
        except OSError:
            continue
        comm = stat[stat.index("(") + 1:stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2:].split()
        out.append((int(d), int(fields[1]), comm))
    return out


def cmdline(pid):
    try:
        with open("/proc/%d/cmdline" % pid, "rb") as f:
            return f.read().replace(b"\0", b" ").decode("utf-8", "replace")
    except OSError:
        return ""


def alive(pid):
    """True while pid exists and is not a zombie."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False
