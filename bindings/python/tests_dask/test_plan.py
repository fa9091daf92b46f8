# SPDX-License-Identifier: MIT
"""lidarflow_dask: what is planned and refused before any chunk runs (CTest: python_dask).

  * a stray frame file far from the others: refused past sequence's 10^6 pairs, else only the
    runs of present frames are chunked and the missing frames reported (exit 1);
  * bad options, preset, format, thread counts or OUT: exit 2 before anything is written;
  * --frames and --format as `lidarflow sequence` reads them.
"""
import filecmp
import os
import shutil
import time
import unittest

from dask_fixture import BIN, CHUNK, FixtureCase, cli, serial_args

if BIN:
    import lidarflow_dask as ld
    from lidarflow_dask import frames


def stray(drive, copy_to, name):
    shutil.copytree(drive, copy_to)
    shutil.copy(os.path.join(copy_to, "image_02", "data", "0000000000.png"),
                os.path.join(copy_to, "image_02", "data", name))
    return copy_to


class Plan(FixtureCase):
    def test_stray_frame_past_the_bound_refused(self):
        drive = stray(self.f.drive, os.path.join(self.f.folder("stray"), "drive"), "9999999999.png")
        out = self.f.folder("stray_out")
        t0 = time.monotonic()
        p = cli(*serial_args(out, drive))
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("spans frames 0..9999999999, more than 1000000 pairs (choose a part with --frames A:B)", p.stderr)
        self.assertLess(time.monotonic() - t0, 30)
        self.assertEqual(os.listdir(out), [])
        # A part of it is computed.
        p = cli(*serial_args(out, drive) + ["--frames", "0:2"])
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(sorted(os.listdir(os.path.join(out, "drive", "flow"))), ["0000000000.png", "0000000001.png"])

    def test_stray_frame_within_the_bound_plans_present_runs(self):
        drive = stray(self.f.drive, os.path.join(self.f.folder("stray2"), "drive"), "0001000000.png")
        s = ld.Source(drive, ld.Settings(self.f.folder("unused"), chunk=CHUNK))
        self.assertEqual([(c["first"], c["last"]) for c in s.chunks], [(0, 3), (3, 6), (6, 8)])
        self.assertEqual(s.gaps, [(9, 999999)])
        self.assertEqual(s.lost, 999992)  # 8->9 .. 999999->1000000
        out = self.f.folder("stray2_out")
        p = cli(*serial_args(out, drive) + ["--frames", "7:1000000"])
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("1 chunk(s) of up to 4 frames", p.stderr)
        self.assertIn("MISSING: %s frames 9..999999: no image_02/data/NNNNNNNNNN.png" % drive, p.stderr)
        self.assertIn("999992 pairs not computed for missing frames", p.stderr)
        self.assertEqual(os.listdir(os.path.join(out, "drive", "flow")), ["0000000007.png"])

    def test_frames_rules_as_sequence(self):
        self.assertEqual(frames.parse_frames("3:5"), (3, 5))
        for bad in ("5:3", "3:3", "3", "a:b", "-1:4", "0:1000001", "00000000001:2", ""):
            with self.assertRaises(frames.FramesError, msg=bad):
                frames.parse_frames(bad)
        self.assertEqual(frames.runs([0, 1, 2, 5, 6, 9], 0, 10), ([(0, 2), (5, 6)], [(3, 4), (7, 8), (10, 10)]))
        self.assertEqual(frames.runs([4], 0, 10), ([], [(0, 3), (5, 10)]))
        self.assertEqual(frames.lost_pairs([(3, 4), (7, 8), (10, 10)], 0, 10), 3 + 3 + 1)

    def test_bad_options_refused_before_planning(self):
        out = os.path.join(self.f.folder("opts"), "out")
        cases = [(["--option", "bogus.key=1"], "unknown option key 'bogus.key'"),
                 (["--option", "stereo.paths=5"], "stereo.paths"),
                 (["--preset", "bogus"], "unknown preset 'bogus'"),
                 (["--threads-per-task", "0"], "--threads-per-task 0"),
                 (["--threads-per-task", "300"], "threads"),
                 (["--format", "jpg"], "unknown result format 'jpg'"),
                 (["--frames", "5:3"], "holds no pair"),
                 (["--chunk-timeout", "-1"], "--chunk-timeout")]
        for extra, message in cases:
            args = serial_args(out, self.f.drive, self.f.log)
            args = [a for a in args if a != "realtime"] if "--preset" in extra else args
            if "--preset" in extra:
                args.remove("--preset")
            if "--threads-per-task" in extra:
                i = args.index("--threads-per-task")
                del args[i:i + 2]
            p = cli(*(args + extra))
            self.assertEqual(p.returncode, 2, (extra, p.stderr))
            self.assertIn(message, p.stderr, extra)
            self.assertNotIn("Traceback", p.stderr, extra)
            self.assertFalse(os.path.exists(out), extra)  # nothing recorded: OUT is not poisoned
        p = cli("--serial", "--out", "", self.f.drive)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("--out: the output folder must be named", p.stderr)

    def test_failed_chunks_record_no_settings(self):
        # Every chunk fails (its tool exits 1): the settings are not kept, other settings then run.
        from dask_fixture import fake_bin
        out = self.f.folder("nosettings")
        bin_dir = fake_bin(self.f.folder("failbin"), "exit 1")
        p = cli(*[a if a != BIN else bin_dir for a in serial_args(out, self.f.drive)] + ["--frames", "0:2"])
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("exit 1", p.stderr)
        state = os.path.join(out, ".lidarflow_dask", "drive")
        self.assertFalse(os.path.exists(os.path.join(state, "settings.json")), os.listdir(state))
        p = cli(*[a if a != "realtime" else "fast" for a in serial_args(out, self.f.drive)] + ["--frames", "0:2"])
        self.assertEqual(p.returncode, 0, p.stderr)

    def test_frames_and_format(self):
        out = self.f.folder("fmt")
        p = cli(*serial_args(out, self.f.drive, self.f.log) + ["--frames", "2:5", "--format", "npy,kitti"])
        self.assertEqual(p.returncode, 0, p.stderr)
        d = os.path.join(out, "drive")
        for folder, exts in (("flow", ("npy", "png")), ("disp_0", ("npy", "png")), ("disp_1", ("npy", "png")),
                             ("valid", ("npy",))):
            self.assertEqual(sorted(os.listdir(os.path.join(d, folder))),
                             sorted("%010d.%s" % (k, e) for k in (2, 3, 4) for e in exts), folder)
        for k in (2, 3, 4):
            n = "flow/%010d.png" % k
            self.assertTrue(filecmp.cmp(os.path.join(d, n), os.path.join(self.f.serial, "drive", n), shallow=False), n)
        from dask_fixture import flows
        self.assertEqual(flows(os.path.join(out, "run.log")), self.f.whole[2:5])
        # Another format into the same OUT computes the files that format lacks.
        p = cli(*serial_args(out, self.f.drive) + ["--frames", "2:5", "--format", "pfm"])
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("1 to compute", p.stderr)
        self.assertEqual(sorted(n for n in os.listdir(os.path.join(d, "flow")) if n.endswith(".pfm")),
                         ["%010d.pfm" % k for k in (2, 3, 4)])


if __name__ == "__main__":
    unittest.main()
