# SPDX-License-Identifier: MIT
"""lidarflow_lcm against the C side (CTest: python_lcm; needs LIDARFLOW_CLI, LIDARFLOW_BRIDGE
and the binding's library, which CTest sets):

  * an input log written by `lidarflow publish-kitti` (lcm-gen's C encoders, liblcm's writer)
    decodes, and re-encoding every message here gives the same bytes;
  * result logs of `lidarflow-lcm-bridge --replay` (float32 and int16 with step 2) decode to the
    scene flow the Python binding (C ABI) computes for the same frames, LiDAR and calibration,
    and points3d() equals the binding's points3d();
  * an input log written by LogWriter from messages built here replays in the bridge (liblcm's
    reader) to the same results.
"""
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import lidarflow_lcm as ll

CLI, BRIDGE = os.environ.get("LIDARFLOW_CLI"), os.environ.get("LIDARFLOW_BRIDGE")
OPTIONS = {"matching.min_coarsest_height": 16, "threads": 2}


def replay(log, out, *extra):
    args = [BRIDGE, "--replay", log, "--out", out] + [a for k, v in OPTIONS.items() for a in ("--option", "%s=%s" % (k, v))]
    p = subprocess.run(args + list(extra), capture_output=True, text=True, timeout=240)
    if p.returncode != 0:
        raise AssertionError("%s exited %d:\n%s" % (" ".join(args), p.returncode, p.stderr))
    return p.stderr


@unittest.skipUnless(CLI and BRIDGE, "LIDARFLOW_CLI / LIDARFLOW_BRIDGE not set (a build without LCM)")
class AgainstTheBridge(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        t = cls.tmp.name
        cls.scene, cls.inlog = os.path.join(t, "scene"), os.path.join(t, "in.log")
        subprocess.run([CLI, "synth", "--out", cls.scene, "--width", "320", "--height", "96", "--frames", "2"],
                       check=True, capture_output=True)
        subprocess.run([CLI, "publish-kitti", "--root", cls.scene, "--lidar", "paper", "--rate", "0",
                        "--lcm-url", "file://%s?mode=w" % cls.inlog], check=True, capture_output=True)
        cls.out_f32, cls.out_i16 = os.path.join(t, "f32.log"), os.path.join(t, "i16.log")
        replay(cls.inlog, cls.out_f32, "--encoding", "float32")
        replay(cls.inlog, cls.out_i16, "--encoding", "int16", "--step", "2")
        cls.inputs = list(ll.read_messages(cls.inlog, strict=True))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def frames(self):
        """stereo_t by utime, lidar_t by utime, and the calibration_t messages of the input log."""
        stereo = {m.utime: m for _, m in self.inputs if isinstance(m, ll.stereo_t)}
        lidar = {m.utime: m for _, m in self.inputs if isinstance(m, ll.lidar_t)}
        cals = [m for _, m in self.inputs if isinstance(m, ll.calibration_t)]
        return stereo, lidar, cals

    def test_c_encoded_inputs_decode_and_reencode_identically(self):
        kinds = [type(m) for _, m in self.inputs]
        self.assertEqual((kinds.count(ll.stereo_t), kinds.count(ll.lidar_t), kinds.count(ll.calibration_t)), (4, 4, 2))
        for event, m in self.inputs:
            self.assertEqual(m.encode(), event.data, event.event_number)
        stereo, lidar, cals = self.frames()
        self.assertEqual(sorted(s.frame_number for s in stereo.values()), [0, 1, 2, 3])
        for s in stereo.values():
            left, right, order = ll.stereo_images(s)
            self.assertEqual(left.shape, (96, 320, 3) if order else (96, 320))
            self.assertGreater(np.std(left.astype(float)), 5)  # a rendered image, not zeros
        for m in lidar.values():
            pts, kind = ll.lidar_points(m)
            self.assertEqual(kind, "disparity")
            self.assertTrue(((pts[:, 0] >= 0) & (pts[:, 0] < 320) & (pts[:, 2] > 0)).all())
        self.assertTrue(all((c.width, c.height) == (320, 96) and c.fx > 0 for c in cals))

    def expected(self, flow):
        """The binding's result and points for the frames (and LiDAR) a scene_flow_t names."""
        import lidarflow  # the ctypes binding (C ABI); lidarflow_lcm itself does not need it
        stereo, lidar, cals = self.frames()
        cal = cals[0]
        with lidarflow.Estimator(cal.fx, cal.fy, cal.cx, cal.cy, cal.baseline, options=OPTIONS) as est:
            for utime, flag, lidar_utime in ((flow.utime0, ll.scene_flow_t.LIDAR_T0, flow.lidar_utime0),
                                             (flow.utime, ll.scene_flow_t.LIDAR_T1, flow.lidar_utime1)):
                pts, kind = ll.lidar_points(lidar[lidar_utime]) if flow.lidar_flags & flag else (None, "disparity")
                left, right, order = ll.stereo_images(stereo[utime])
                est.push(left, right, lidar=pts, lidar_kind=kind, timestamp=utime, colour_order=order)
            return est.result(), est.points3d(), cal

    def expected_ego(self, flow):
        """The binding's ego_motion() for the frames (and LiDAR) a scene_flow_t names."""
        import lidarflow
        stereo, lidar, cals = self.frames()
        cal = cals[0]
        with lidarflow.Estimator(cal.fx, cal.fy, cal.cx, cal.cy, cal.baseline, options=OPTIONS) as est:
            for utime, flag, lidar_utime in ((flow.utime0, ll.scene_flow_t.LIDAR_T0, flow.lidar_utime0),
                                             (flow.utime, ll.scene_flow_t.LIDAR_T1, flow.lidar_utime1)):
                pts, kind = ll.lidar_points(lidar[lidar_utime]) if flow.lidar_flags & flag else (None, "disparity")
                left, right, order = ll.stereo_images(stereo[utime])
                est.push(left, right, lidar=pts, lidar_kind=kind, timestamp=utime, colour_order=order)
            return est.ego_motion()

    def test_ego_motion_beside_each_result(self):
        # The bridge's C encoder (lcm-gen), read back by this package's decoder with its checks.
        egos = [m for _, m in ll.read_messages(self.out_f32, channels=ll.CHANNELS["ego_motion"], strict=True)]
        flows = self.flows(self.out_f32)
        self.assertEqual(len(egos), len(flows))
        for ego, flow in zip(egos, flows):
            self.assertIsInstance(ego, ll.ego_motion_t)
            self.assertEqual((ego.utime, ego.utime0, ego.sequence), (flow.utime, flow.utime0, flow.sequence))
            self.assertEqual(ego.state, ll.ego_motion_t.STATE_OK)
            T, inliers = self.expected_ego(flow)
            np.testing.assert_array_equal(ego.matrix(), T)
            self.assertEqual(ego.inliers, inliers)
            self.assertGreater(ego.candidates, 0)
        # Old consumers: the flow channel carries only scene_flow_t, as before.
        self.assertTrue(all(isinstance(m, ll.scene_flow_t)
                            for _, m in ll.read_messages(self.out_f32, channels=ll.CHANNELS["flow"])))

    def test_quality_beside_each_result(self):
        # The bridge's C encoder (lcm-gen), read back with this package's checks: these frames
        # are a correct rig.
        got = [m for _, m in ll.read_messages(self.out_f32, channels=ll.CHANNELS["quality"], strict=True)]
        flows = self.flows(self.out_f32)
        self.assertEqual([(q.utime, q.utime0, q.sequence) for q in got],
                         [(f.utime, f.utime0, f.sequence) for f in flows])
        self.assertEqual([(q.flags, q.reason, q.states()) for q in got], [(0, "", ())] * len(flows))

    def flows(self, log):
        got = [m for _, m in ll.read_messages(log, channels=ll.CHANNELS["flow"], strict=True)]
        self.assertEqual(len(got), 2)
        return got

    def test_float32_results_equal_the_binding(self):
        for flow in self.flows(self.out_f32):
            self.assertEqual(flow.lidar_flags, 3)
            want, want_xyz, cal = self.expected(flow)
            a = ll.flow_arrays(flow)
            valid = want["valid"] == 1
            np.testing.assert_array_equal(a["valid"], valid)
            self.assertGreater(valid.mean(), 0.5)
            for k in ("u", "v", "d0", "d1"):
                np.testing.assert_array_equal(a[k][valid], want[k][valid], k)
                self.assertTrue(np.isnan(a[k][~valid]).all())
            xyz = ll.points3d(flow, cal)
            np.testing.assert_array_equal(xyz["valid"], want_xyz["valid"] == 1)
            for k in ("points", "motion"):
                np.testing.assert_array_equal(xyz[k], want_xyz[k], k)  # NaN where not valid, in both
            ok = xyz["valid"]
            np.testing.assert_allclose(xyz["points1"][ok], (want_xyz["points"] + want_xyz["motion"])[ok],
                                       rtol=1e-5, atol=1e-5)

    def test_int16_step2_results_equal_the_binding(self):
        for flow in self.flows(self.out_i16):
            want, _, cal = self.expected(flow)
            self.assertEqual((flow.step, flow.width, flow.height, flow.encoding), (2, 160, 48, 2))
            # Our encoder applied to the binding's planes writes the bridge's bytes exactly.
            ours = ll.scene_flow_message(want["u"], want["v"], want["d0"], want["d1"], want["valid"], step=2)
            for k in ("u", "v", "d0", "d1", "valid"):
                self.assertEqual(getattr(ours, k), getattr(flow, k), k)
            a = ll.flow_arrays(flow)
            sub = {k: want[k][::2, ::2] for k in want}
            valid = sub["valid"] == 1
            np.testing.assert_array_equal(a["valid"], valid)
            for k in ("u", "v", "d0", "d1"):
                self.assertLessEqual(np.abs(a[k][valid] - sub[k][valid]).max(), 1 / 128, k)
            xs, ys = ll.pixel_grid(flow)
            self.assertEqual((xs[0, -1], ys[-1, 0]), (318, 94))
            xyz = ll.points3d(flow, cal)
            self.assertTrue(np.isfinite(xyz["points"][xyz["valid"]]).all())

    def test_status_accounts_for_every_frame(self):
        status = [m for _, m in ll.read_messages(self.out_f32, channels=ll.CHANNELS["status"])]
        self.assertGreaterEqual(len(status), 1)
        last = status[-1]
        self.assertEqual((last.stereo_received, last.stereo_processed, last.results_published, last.lidar_received),
                         (4, 4, 2, 4))
        self.assertEqual(last.last_error, "")

    def test_python_written_inputs_replay_to_the_same_results(self):
        # Inputs rebuilt from arrays with the builders (not copied bytes), written by LogWriter,
        # read by the bridge with liblcm.
        path, out = os.path.join(self.tmp.name, "py_in.log"), os.path.join(self.tmp.name, "py_out.log")
        with ll.LogWriter(path) as w:
            for event, m in self.inputs:
                if isinstance(m, ll.stereo_t):
                    left, right, order = ll.stereo_images(m)
                    m = ll.stereo_message(left, right, m.utime, m.sequence, m.frame_number, colour_order=order)
                elif isinstance(m, ll.lidar_t):
                    pts, kind = ll.lidar_points(m)
                    m = ll.lidar_message(pts, m.utime, frame=kind)
                else:
                    m = ll.calibration_message(m.fx, m.fy, m.cx, m.cy, m.baseline, m.utime, m.width, m.height)
                w.write_message(event.channel, m, event.utime)
        err = replay(path, out, "--encoding", "float32")
        self.assertIn("stereo processed 4, dropped 0", err)
        for a, b in zip(self.flows(out), self.flows(self.out_f32)):
            for k in ("utime", "utime0", "lidar_flags", "u", "v", "d0", "d1", "valid"):
                self.assertEqual(getattr(a, k), getattr(b, k), k)

    def test_readme_example_reads_the_result_log(self):
        # examples/lcm_read_flow.py, as README's "Running on LCM" runs it.
        here = os.path.dirname(os.path.abspath(__file__))
        script = os.path.join(here, "..", "..", "..", "examples", "lcm_read_flow.py")
        p = subprocess.run([sys.executable, script, self.out_f32, self.inlog], capture_output=True, text=True,
                           timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        lines = p.stdout.splitlines()
        self.assertEqual(lines[-1], "2 scene flow result(s)")
        for flow, line in zip(self.flows(self.out_f32), lines):
            self.assertIn("t0 %d -> t1 %d us: 320x96 (step 1)" % (flow.utime0, flow.utime), line)
            self.assertIn("median u %.2f px" % np.nanmedian(ll.flow_arrays(flow)["u"]), line)
            self.assertIn("median depth", line)


if __name__ == "__main__":
    unittest.main()
