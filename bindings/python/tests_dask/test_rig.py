# SPDX-License-Identifier: MIT
"""lidarflow_dask with a drive's rig given as options (CTest: python_dask):

  * --calib (an OpenCV stereo file made from the drive's calib_cam_to_cam.txt) and --calib-velo,
    given as relative paths, reach every chunk of a local cluster as absolute paths (the chunk
    processes run in /) and give lidarflow sequence's results with the same options byte for
    byte; the drive has no calibration files of its own;
  * a rerun with the calibration file changed is refused (results of another rig);
  * a calib file that is not there, an unreadable rig, a rig for an LCM log: exit 2 with the
    reason before any chunk runs.
"""
import os
import shutil
import subprocess
import unittest

from dask_fixture import BIN, CHUNK, PY, FixtureCase, fake_bin, lidarflow, same_tree, serial_args

WIDTH, HEIGHT = 320, 96  # the fixture drive's


def opencv_stereo(calib_cam_to_cam):
    """An OpenCV stereo calibration (YAML) of the rectified rig in a KITTI calib_cam_to_cam.txt."""
    with open(calib_cam_to_cam) as f:
        rows = dict(line.split(":", 1) for line in f if ":" in line)
    p2, p3 = ([float(x) for x in rows[k].split()] for k in ("P_rect_02", "P_rect_03"))

    def matrix(name, n_rows, n_cols, data):
        return "%s: !!opencv-matrix\n   rows: %d\n   cols: %d\n   dt: d\n   data: [ %s ]\n" % (
            name, n_rows, n_cols, ", ".join(repr(float(v)) for v in data))
    k = [p2[0], 0, p2[2], 0, p2[5], p2[6], 0, 0, 1]
    return ("%%YAML:1.0\n---\nimage_width: %d\nimage_height: %d\n" % (WIDTH, HEIGHT) + matrix("M1", 3, 3, k) +
            matrix("D1", 1, 5, [0] * 5) + matrix("M2", 3, 3, k) + matrix("D2", 1, 5, [0] * 5) +
            matrix("R", 3, 3, [1, 0, 0, 0, 1, 0, 0, 0, 1]) + matrix("T", 3, 1, [(p3[3] - p2[3]) / p2[0], 0, 0]))


def run(args, cwd):
    return subprocess.run([PY, "-m", "lidarflow_dask"] + args, capture_output=True, text=True, timeout=300, cwd=cwd)


class Rig(FixtureCase):
    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        f = cls.f
        # The drive without calibration files; its rig in rig/, as a user keeps their own.
        cls.dir = f.folder("rig")
        cls.drive = os.path.join(cls.dir, "drive")
        shutil.copytree(f.drive, cls.drive)
        os.makedirs(os.path.join(cls.dir, "rig"))
        with open(os.path.join(cls.dir, "rig", "stereo.yml"), "w") as out:
            out.write(opencv_stereo(os.path.join(f.drive, "calib_cam_to_cam.txt")))
        os.remove(os.path.join(cls.drive, "calib_cam_to_cam.txt"))
        os.rename(os.path.join(cls.drive, "calib_velo_to_cam.txt"), os.path.join(cls.dir, "rig", "velo.txt"))
        cls.rig = ["--calib", "rig/stereo.yml", "--calib-velo", "rig/velo.txt", "--strict"]
        # A chunk process that would read relative paths from the submitting folder fails in /.
        cls.bin = fake_bin(os.path.join(cls.dir, "bin"), "cd /")

    def args(self, out, *extra, sources=("drive",)):
        """The run of frames 0:5 of the drive (chunks 0:3 and 3:5, both warmed up from frame 0)."""
        return [a if a != BIN else self.bin for a in serial_args(out)] + ["--frames", "0:5", "--format", "npy"] + \
            list(extra) + list(sources)

    def test_calib_options_reach_every_chunk(self):
        ref = os.path.join(self.dir, "serial")
        rig = [os.path.join(self.dir, a) if a.startswith("rig/") else a for a in self.rig]
        lidarflow("sequence", "--drive", self.drive, "--out", ref, "--frames", "0:5", "--format", "npy",
                  "--preset", "realtime", "--threads", "1", "--quiet", *rig)
        p = run(["--workers", "2"] + self.args("out", *self.rig)[1:], cwd=self.dir)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("2 chunk(s) of up to %d frames" % CHUNK, p.stderr)
        got = os.path.join(self.dir, "out", "drive")
        for sub in ("flow", "disp_0", "disp_1", "valid", "manifest"):
            self.assertEqual(same_tree(self, os.path.join(ref, sub), os.path.join(got, sub)), 5, sub)
        # The same rig again: nothing to compute; the file changed: results of another rig, refused.
        p = run(self.args("out", *self.rig), cwd=self.dir)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("0 to compute (2 complete)", p.stderr)
        with open(os.path.join(self.dir, "rig", "stereo.yml"), "a") as f:
            f.write("# recalibrated\n")
        p = run(self.args("out", *self.rig), cwd=self.dir)
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("computed with other settings", p.stderr)
        self.assertIn("use --force", p.stderr)

    def test_bad_rig_refused_before_any_chunk(self):
        marker = os.path.join(self.dir, "chunk-ran")
        bin_dir = fake_bin(self.f.folder("markbin"), "touch %s" % marker)
        garbage = os.path.join(self.dir, "garbage.yml")
        with open(garbage, "w") as f:
            f.write("not a calibration\n")
        cases = [(["--calib", "rig/missing.yml"], "--calib rig/missing.yml: no such file (%s)"
                  % os.path.join(self.dir, "rig", "missing.yml")),
                 (["--calib", "rig/stereo.yml,rig/right.yaml"], "--calib rig/right.yaml: no such file"),
                 (["--calib", "rig/stereo.yml", "--calib-velo", "rig"], "--calib-velo rig: not a file"),
                 (["--calib", garbage], "garbage.yml: not a KITTI calib_cam_to_cam file"),
                 (["--fx", "185.6"], "a rig by numbers needs --fx, --cx, --cy and --baseline"),
                 (["--calib", "rig/stereo.yml"], "an LCM log carries its calibration")]
        for extra, message in cases:
            out = os.path.join(self.dir, "bad_out")
            sources = ("drive", self.f.log) if "LCM" in message else ("drive",)
            args = [a if a != self.bin else bin_dir for a in self.args(out, *extra, sources=sources)]
            p = run(args, cwd=self.dir)
            self.assertEqual(p.returncode, 2, (extra, p.stderr))
            self.assertIn(message, p.stderr, extra)
            self.assertNotIn("Traceback", p.stderr, extra)
            self.assertFalse(os.path.exists(marker), extra)
            self.assertFalse(os.path.exists(out), extra)


if __name__ == "__main__":
    unittest.main()
