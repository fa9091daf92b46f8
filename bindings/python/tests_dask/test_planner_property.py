# SPDX-License-Identifier: MIT
"""Property test of lidarflow_dask's planner (CTest: python_dask; seeded, a few seconds, no
executables needed): random drives (frame file names near and far, bad names, folders named
like frames), random LCM logs (events, garbage, cut off), random --frames / --chunk / --format,
and random state files (markers, settings: valid, garbage, huge, nested, /dev/zero, folders,
FIFOs). Planning either refuses with a message (SourceError / ValueError) or returns chunks
that hold only present frames, each pair at most once, at most MAX_PAIRS pairs; it never raises
anything else and never plans more chunks than frames listed."""
import json
import os
import random
import shutil
import tempfile
import time
import unittest
import warnings

import lidarflow_lcm as ll
from lidarflow_dask import chunks, frames, runner, state
from lidarflow_dask.sources import source_name

SEED = 20261203
ROUNDS = 150


def frame_numbers(rng):
    kind = rng.random()
    n = rng.randint(0, 12)
    if kind < 0.4:
        return rng.sample(range(0, 40), min(n, 40))
    if kind < 0.6:  # a stray file near or past the bound
        return list(range(n)) + [rng.choice([frames.MAX_PAIRS - 1, frames.MAX_PAIRS, frames.MAX_PAIRS + 1,
                                             9999999999, rng.randint(0, 9999999999)])]
    if kind < 0.8:
        base = rng.randint(0, 9999999999 - 20)
        return [base + k for k in range(n)]
    return [rng.randint(0, 9999999999) for _ in range(n)]


BAD_NAMES = ["12.png", "00000000001.png", "000000000a.png", "0000000001.PNG", "0000000001.png.tmp", ".png",
             "-000000001.png", " 000000001.png", "0000000001.jpg"]


def make_drive(rng, path):
    data = os.path.join(path, "image_02", "data")
    os.makedirs(data)
    listed = set()
    for k in frame_numbers(rng):
        name = "%010d.png" % k
        if rng.random() < 0.1:
            os.mkdir(os.path.join(data, name))  # listed like sequence lists it
        else:
            open(os.path.join(data, name), "wb").close()
        listed.add(k)
    for name in rng.sample(BAD_NAMES, rng.randint(0, 3)):
        open(os.path.join(data, name), "wb").close()
    return sorted(listed)


def make_log(rng, path):
    kind = rng.random()
    if kind < 0.6:
        with ll.LogWriter(path) as w:
            for i in range(rng.randint(0, 15)):
                channel = rng.choice(["LIDARFLOW_STEREO", "LIDARFLOW_STEREO", "LIDARFLOW_LIDAR", "OTHER"])
                w.write(channel, bytes(rng.randint(0, 40)), 1000 * i)
        if rng.random() < 0.3:  # cut off mid-event
            size = os.path.getsize(path)
            with open(path, "r+b") as f:
                f.truncate(rng.randint(4, max(4, size)))
    else:
        with open(path, "wb") as f:
            f.write(ll.eventlog.SYNC.to_bytes(4, "big") + bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 200))))


def state_file(rng, path, first, last):
    """A marker-like or settings-like file at path, good or bad."""
    if os.path.lexists(path):
        return
    kind = rng.randrange(9)
    if kind == 0:
        data = json.dumps({"host": "h", "pairs": last - first, "seconds": 1.5, "frames": [first, last]})
    elif kind == 1:
        data = json.dumps({"host": "h", "pairs": rng.choice([1e308, -1, 2 ** 70, "3", None, True]), "seconds": 1,
                           "frames": [first, last]})
    elif kind == 2:
        data = rng.choice(["", "null", "[]", "{}", "{\"kind\": \"drive\", \"preset\": null, \"options\": []}",
                           "Infinity", "[" * 5000, "1" * 5000, "{\"host\": \"h\"" * 3])
    elif kind == 3:
        data = bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 100)))
    elif kind == 4:
        data = "x" * (state.MAX_STATE_BYTES + 1)
    elif kind == 5:
        os.symlink("/dev/zero", path)
        return
    elif kind == 6:
        os.mkdir(path)
        return
    elif kind == 7:
        os.mkfifo(path)
        return
    else:
        os.symlink(path + ".nowhere", path)
        return
    with open(path, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


def make_state(rng, out, name, listed):
    d = state.state_dir(out, name)
    os.makedirs(d, exist_ok=True)
    if rng.random() < 0.5:
        state_file(rng, os.path.join(d, "settings.json"), 0, 1)
    near = listed or [0]
    for _ in range(rng.randint(0, 6)):
        a = rng.choice(near)
        b = a + rng.choice([1, 2, 3, 19, 1000])
        state_file(rng, os.path.join(d, "%010d-%010d.%s" % (a, b, rng.choice(["done", "log"]))), a, b)


class PlannerProperty(unittest.TestCase):
    def test_random_sources_and_state(self):
        rng = random.Random(SEED)
        warnings.simplefilter("ignore", ll.LogWarning)  # torn logs are read as far as they go
        t0 = time.monotonic()
        refused = planned = 0
        for round_ in range(ROUNDS):
            tmp = tempfile.mkdtemp(prefix="lidarflow_dask-prop-")
            try:
                paths, listed = [], {}
                for k in range(rng.randint(1, 2)):
                    if rng.random() < 0.6:
                        p = os.path.join(tmp, rng.choice(["drive", "d%d" % k, "..x", ".lidarflow_dask", "a b"]))
                        if os.path.exists(p):
                            continue
                        listed[p] = make_drive(rng, p)
                    else:
                        p = os.path.join(tmp, rng.choice(["run.log", "...log", ".log", "x%d.log" % k, "log"]))
                        if os.path.exists(p):
                            continue
                        make_log(rng, p)
                        listed[p] = None
                    paths.append(p)
                out = os.path.join(tmp, "out")
                fr = None
                if rng.random() < 0.3:
                    a = rng.choice([0, 3, 9999999990, rng.randint(0, 10 ** 6)])
                    fr = (a, a + rng.choice([1, 2, 7, frames.MAX_PAIRS]))
                chunk = rng.choice([2, 3, 5, 20, 10 ** 7])
                formats = rng.sample(["kitti", "flo", "pfm", "npy"], rng.randint(1, 2))
                force = rng.random() < 0.2
                for p in paths:
                    if rng.random() < 0.7:
                        make_state(rng, out, source_name(p), listed[p] or [])
                with self.subTest(round=round_, paths=[os.path.basename(p) for p in paths]):
                    try:
                        settings = runner.Settings(out, chunk=chunk, frames=fr, formats=formats, force=force)
                        sources = [runner.Source(p, settings) for p in paths]
                        pending, done, notes = runner.prepare(sources, settings)
                    except ValueError as e:  # SourceError, FramesError, StateError: a message
                        self.assertTrue(str(e))
                        refused += 1
                        continue
                    planned += 1
                    self.check_plan(sources, pending, done, listed, settings)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        print("planner property: %d planned, %d refused" % (planned, refused))
        self.assertGreater(refused, 10)
        self.assertGreater(planned, 10)
        self.assertLess(time.monotonic() - t0, 60)

    def check_plan(self, sources, pending, done, listed, settings):
        keys = {(c["source"], c["first"]) for s in sources for c in s.chunks}
        self.assertLessEqual({(c["source"], c["first"]) for c in pending}, keys)
        for s in sources:
            self.assertLessEqual(s.last - s.first, frames.MAX_PAIRS)
            present = set(listed[s.path]) if listed[s.path] is not None else None
            pairs = set()
            for c in s.chunks:
                self.assertLess(c["first"], c["last"])
                self.assertLessEqual(c["last"] - c["first"], settings.chunk - 1)
                self.assertTrue(s.first <= c["first"] and c["last"] <= s.last)
                if present is not None:
                    self.assertTrue(all(k in present for k in range(c["first"], c["last"] + 1)), c)
                for k in range(c["first"], c["last"]):
                    self.assertNotIn(k, pairs)
                    pairs.add(k)
                self.assertTrue(chunks.marker_path(c).startswith(os.path.join(settings.out, state.STATE_DIR) + os.sep))
            if present is not None:
                self.assertLessEqual(len(s.chunks), len(present))
            self.assertEqual(len(pairs) + s.lost, s.last - s.first)
        self.assertLessEqual(done, sum(c["last"] - c["first"] for s in sources for c in s.chunks))


if __name__ == "__main__":
    unittest.main()
