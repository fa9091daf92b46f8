# SPDX-License-Identifier: MIT
"""lidarflow_dask on a small synthetic drive and LCM log (CTest: python_dask; needs
LIDARFLOW_BIN_DIR, the build tree, which CTest sets, and Debian's python3-distributed):

  * a local cluster of 2 workers x 1 thread writes byte for byte the serial run's drive results
    and the same LCM results (compute_seconds aside: a timing), which are the whole log's replay;
  * a worker killed mid-chunk: its chunk process dies with it (parent-death signal) and the
    chunk is rerun elsewhere; every pair is in the result log exactly once;
  * a corrupt frame in the middle of a drive: its chunk is reported with source and frames,
    exit 1, and only that frame's two pairs are missing;
  * rerunning the command computes nothing; --force recomputes everything.
"""
import filecmp
import io
import os
import shutil
import signal
import threading
import time
import unittest

from dask_fixture import BIN, CHUNK, FixtureCase, alive, cli, egos, flows, lidarflow, processes, same_tree

if BIN:
    import lidarflow_dask as ld
    from lidarflow_dask import poses as ldp
    from lidarflow_dask.cluster import local_cluster


class Dask(FixtureCase):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        f = cls.f  # the serial run, the reference of the others
        cls.tmp, cls.drive, cls.log, cls.settings = f, f.drive, f.log, f.settings
        cls.serial, cls.serial_rc, cls.serial_summary = f.serial, f.serial_rc, f.serial_summary
        cls.whole, cls.whole_ego = f.whole, f.whole_ego

    def test_serial_run_computes_every_pair_once(self):
        self.assertEqual(self.serial_rc, 0, self.serial_summary)
        self.assertEqual(self.serial_summary["pairs"], 8 + 7)
        names = sorted(os.listdir(os.path.join(self.serial, "drive", "flow")))
        self.assertEqual(names, ["%010d.png" % k for k in range(8)])
        got = flows(os.path.join(self.serial, "run.log"))
        self.assertEqual(len(got), 7)
        # Chunks 0:3, 3:6, 6:7 of the log: their results are the whole log's replay's.
        self.assertEqual(got, self.whole)
        self.assertEqual(len(self.whole_ego), 7)
        self.assertEqual(egos(os.path.join(self.serial, "run.log")), self.whole_ego)

    def test_drive_poses_chained(self):
        """The chunks' poses files chain into the drive's poses.txt: frames 0..6 (the first
        chunk, and the second warmed up from frame 0) as `lidarflow sequence` over the whole
        drive writes them, the rest within 5 cm."""
        whole = os.path.join(self.tmp.tmp, "whole-drive")
        lidarflow("sequence", "--drive", self.drive, "--out", whole, "--preset", "realtime", "--threads", "1",
                  "--quiet")

        def rows(path):
            with open(path) as f:
                return [[float(x) for x in line.split()] for line in f]
        want, got = rows(os.path.join(whole, "poses.txt")), rows(os.path.join(self.serial, "drive", "poses.txt"))
        self.assertEqual(len(got), 9)
        for k, (a, b) in enumerate(zip(want, got)):
            tol = 1e-6 if k <= 6 else 0.05
            for i in (3, 7, 11):
                self.assertLess(abs(a[i] - b[i]), tol, "frame %d" % k)
        # A chunk's poses file gone: the trajectory stops where it is missing, and says so.
        out = self.tmp.folder("poses")
        for c in ({"first": 0, "last": 3}, {"first": 3, "last": 6}):
            shutil.copy(os.path.join(self.serial, "drive", "poses_%010d-%010d.txt" % (c["first"], c["last"])),
                        os.path.join(out, "poses_%010d-%010d.txt" % (c["first"], c["last"])))
        last, why = ldp.merge(out, [{"first": 0, "last": 3}, {"first": 3, "last": 6}, {"first": 6, "last": 8}])
        self.assertEqual(last, 6)
        self.assertIn("poses_0000000006-0000000008.txt is missing", why)
        self.assertEqual(len(rows(os.path.join(out, "poses.txt"))), 7)

    def test_local_cluster_equals_serial_run(self):
        out = os.path.join(self.tmp.tmp, "cluster")
        with local_cluster(2, 1) as client:
            rc, summary = ld.run([self.drive, self.log], ld.Settings(out, **self.settings), client=client,
                                 stream=io.StringIO())
        self.assertEqual(rc, 0, summary)
        self.assertEqual(summary["pairs"], 15)
        self.assertGreaterEqual(same_tree(self, os.path.join(self.serial, "drive"), os.path.join(out, "drive")), 8 * 3)
        self.assertEqual(flows(os.path.join(out, "run.log")), self.whole)

    def test_killed_worker_every_pair_exactly_once(self):
        out = os.path.join(self.tmp.tmp, "killed")
        with local_cluster(2, 1) as client:
            pids = set(client.run(os.getpid).values())
            box = {}
            runner = threading.Thread(target=lambda: box.update(r=ld.run(
                [self.log], ld.Settings(out, preset="realtime", chunk=3, threads=1), client=client,
                stream=io.StringIO())))
            runner.start()
            # The first chunk process seen under a worker is stopped (so it cannot finish), then
            # its worker is killed: the parent-death signal must end it.
            child = worker = None
            deadline = time.monotonic() + 120
            while child is None and time.monotonic() < deadline:
                for pid, ppid, comm in processes():
                    if ppid in pids and comm.startswith("lidarflow-lcm"):
                        try:
                            os.kill(pid, signal.SIGSTOP)
                        except ProcessLookupError:
                            continue
                        child, worker = pid, ppid
                        break
                time.sleep(0.005)
            self.assertIsNotNone(child, "no chunk process seen")
            os.kill(worker, signal.SIGKILL)
            try:
                for _ in range(500):
                    if not alive(child):
                        break
                    time.sleep(0.02)
                self.assertFalse(alive(child), "the chunk process outlived its killed worker")
            finally:
                if alive(child):
                    os.kill(child, signal.SIGKILL)
            runner.join(240)
        rc, summary = box["r"]
        self.assertEqual(rc, 0, summary)
        got = flows(os.path.join(out, "run.log"))
        self.assertEqual(len(got), 7)
        self.assertEqual(got, self.whole)  # each pair once, in order

    def test_corrupt_frame_reported_and_only_its_pairs_missing(self):
        drive = os.path.join(self.tmp.tmp, "bad_drive")
        shutil.copytree(self.drive, drive)
        with open(os.path.join(drive, "image_02", "data", "0000000005.png"), "r+b") as f:
            f.truncate(40)  # a cut-off PNG
        out = os.path.join(self.tmp.tmp, "bad")
        p = cli("--serial", "--out", out, "--preset", "realtime", "--chunk", str(CHUNK), "--threads-per-task", "1",
                "--bin-dir", BIN, drive)
        self.assertEqual(p.returncode, 1, p.stderr)
        # Frame 5 is in chunk 3:6: that chunk failed, the others did not.
        self.assertRegex(p.stderr, r"FAILED: %s frames 3:6: exit 3" % drive)
        self.assertIn("1 of 3 chunks failed", p.stderr)
        names = sorted(os.listdir(os.path.join(out, "bad_drive", "flow")))
        self.assertEqual(names, ["%010d.png" % k for k in range(8) if k not in (4, 5)])
        for n in names:
            self.assertTrue(filecmp.cmp(os.path.join(out, "bad_drive", "flow", n),
                                        os.path.join(self.serial, "drive", "flow", n), shallow=False), n)

    def test_rerun_skips_and_force_recomputes(self):
        # The serial run's folder, copied (times kept): the same command finds it complete.
        out = os.path.join(self.tmp.tmp, "rerun")
        shutil.copytree(self.serial, out)
        args = ["--serial", "--out", out, "--preset", "realtime", "--chunk", str(CHUNK), "--threads-per-task", "1",
                "--bin-dir", BIN, self.drive, self.log]
        stamp = {f: os.stat(os.path.join(out, f)).st_mtime_ns for f in ("run.log", "drive/flow/0000000000.png")}
        p = cli(*args)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("0 to compute (6 complete)", p.stderr)
        self.assertIn("0 pairs computed", p.stderr)
        self.assertIn("15 complete before", p.stderr)
        for f, t in stamp.items():
            self.assertEqual(os.stat(os.path.join(out, f)).st_mtime_ns, t, f)
        # Other settings into the same folder are refused.
        p = cli(*[a if a != "realtime" else "fast" for a in args])
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("use --force", p.stderr)
        p = cli(*(args + ["--force"]))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("15 pairs computed", p.stderr)
        for f, t in stamp.items():
            self.assertGreater(os.stat(os.path.join(out, f)).st_mtime_ns, t, f)
        self.assertEqual(flows(os.path.join(out, "run.log")), self.whole)

    def test_bad_sources_and_missing_tools(self):
        p = cli("--serial", "--out", os.path.join(self.tmp.tmp, "x"), self.tmp.tmp)
        self.assertEqual(p.returncode, 2)
        self.assertIn("not a KITTI raw drive", p.stderr)
        p = cli("--serial", "--out", os.path.join(self.tmp.tmp, "x"), os.path.join(self.drive, "calib_cam_to_cam.txt"))
        self.assertEqual(p.returncode, 2)
        self.assertIn("neither a drive folder nor an LCM log", p.stderr)
        empty = os.path.join(self.tmp.tmp, "empty_bin")
        os.makedirs(empty, exist_ok=True)
        p = cli("--serial", "--out", os.path.join(self.tmp.tmp, "x"), "--bin-dir", empty, self.log)
        self.assertEqual(p.returncode, 1)
        self.assertIn("lidarflow-lcm-bridge not found in %s" % empty, p.stderr)

    def test_plan_shares_one_frame(self):
        self.assertEqual(ld.plan(0, 7, 3), [(0, 2), (2, 4), (4, 6), (6, 7)])
        self.assertEqual(ld.plan(5, 6, 20), [(5, 6)])
        pairs = [(a, a + 1) for s, e in ld.plan(3, 100, 7) for a in range(s, e)]
        self.assertEqual(pairs, [(a, a + 1) for a in range(3, 100)])



if __name__ == "__main__":
    unittest.main()
