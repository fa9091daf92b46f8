# SPDX-License-Identifier: MIT
"""Tests of the lidarflow Python binding (python3 -m unittest, run by CTest as python_binding).

Synthetic scene with exact truth: a textured fronto-parallel plane at disparity D moves by
(TU, TV) px, so every pixel's scene flow is (TU, TV, D, D)."""
import ctypes
import gc
import logging
import os
import subprocess
import sys
import threading
import unittest

import numpy as np

import lidarflow
from lidarflow import _lib

W, H = 160, 64
FAST = {"matching.min_coarsest_height": 16}  # a second pyramid level on 64 px high images
CAL = dict(fx=100.0, fy=100.0, cx=80.0, cy=32.0, baseline=0.5)
KITTI_CAM = os.path.join(os.environ.get("LIDARFLOW_KITTI_DIR", "/nonexistent"), "calib_cam_to_cam", "000002.txt")


def make_scene(seed=7, d=10, tu=3, tv=1, width=W, height=H):
    """(left0, right0, left1, right1) uint8 gray images of the moving plane."""
    rng = np.random.RandomState(seed)
    m = 32
    cells = rng.randint(0, 256, size=((height + 2 * m) // 2 + 1, (width + 2 * m) // 2 + 1))
    world = np.kron(cells, np.ones((2, 2)))
    blurred = sum(np.roll(np.roll(world, dy, 0), dx, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)) / 9.0
    world = blurred.astype(np.uint8)

    def view(dx, dy):  # image(x, y) = world(x + dx, y + dy)
        return np.ascontiguousarray(world[m + dy:m + dy + height, m + dx:m + dx + width])

    return view(0, 0), view(d, 0), view(-tu, -tv), view(d - tu, -tv)


def grid_lidar(d, step=16, width=W, height=H):
    ys, xs = np.mgrid[step // 2:height:step, step // 2:width:step]
    return np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, d)], axis=1).astype(np.float32)


def run_pair(scene, lidar=None, options=None, **push_kw):
    with lidarflow.Estimator(options=dict(FAST, **(options or {})), **CAL) as est:
        assert not est.push(scene[0], scene[1], lidar, timestamp=0, **push_kw)
        assert est.push(scene[2], scene[3], lidar, timestamp=100000, **push_kw)
        return est.result()


def accuracy(r, tu=3, tv=1, d=10):
    ok = ((np.abs(r["u"] - tu) < 1) & (np.abs(r["v"] - tv) < 1) & (np.abs(r["d0"] - d) < 1) &
          (np.abs(r["d1"] - d) < 1) & (r["valid"] == 1))
    return ok.mean()


def same(a, b):
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f") for k in a)


class RoundTrip(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = make_scene()
        cls.lidar = grid_lidar(10)
        cls.est = lidarflow.Estimator(options=FAST, **CAL)
        cls.est.push(cls.scene[0], cls.scene[1], cls.lidar, timestamp=5)
        cls.est.push(cls.scene[2], cls.scene[3], cls.lidar, timestamp=7)
        cls.ref = cls.est.result()

    @classmethod
    def tearDownClass(cls):
        cls.est.close()

    def test_result_is_accurate(self):
        self.assertGreater(accuracy(self.ref), 0.95)
        self.assertEqual(self.ref["u"].shape, (H, W))
        self.assertEqual(self.ref["u"].dtype, np.float32)
        self.assertEqual(self.ref["valid"].dtype, np.uint8)

    def test_info(self):
        info = self.est.info()
        self.assertEqual((info["width"], info["height"]), (W, H))
        self.assertEqual((info["t0_us"], info["t1_us"]), (5, 7))
        self.assertEqual(info["last_stage"], "interpolation")
        self.assertIn("interpolation", [name for name, _ in info["timings"]])
        self.assertGreater(info["total_seconds"], 0)

    def test_result_into_preallocated_padded_arrays(self):
        big_u = np.full((H, W + 8), -7.0, np.float32)
        big_valid = np.full((H, W + 5), 9, np.uint8)
        out = {"u": big_u[:, :W], "valid": big_valid[:, :W]}
        ret = self.est.result(out=out)
        self.assertIs(ret, out)
        self.assertTrue(np.shares_memory(out["u"], big_u))  # written in place, not replaced
        np.testing.assert_array_equal(big_u[:, :W], self.ref["u"])
        np.testing.assert_array_equal(big_valid[:, :W], self.ref["valid"])
        self.assertTrue((big_u[:, W:] == -7.0).all())  # the padding is untouched
        self.assertTrue((big_valid[:, W:] == 9).all())
        self.assertEqual(set(ret), {"u", "valid"})  # only the planes asked for

    def test_flow_is_h_w_2(self):
        f = self.ref["flow"]
        self.assertEqual((f.shape, f.dtype), ((H, W, 2), np.float32))
        np.testing.assert_array_equal(f[..., 0], self.ref["u"])
        np.testing.assert_array_equal(f[..., 1], self.ref["v"])
        out = {"flow": np.full((H, W, 2), -7.0, np.float32)}
        self.assertEqual(set(self.est.result(out=out)), {"flow"})  # u and v only as scratch
        np.testing.assert_array_equal(out["flow"], f)

    def test_points3d(self):
        p = self.est.points3d()
        self.assertEqual(p["points"].shape, (H, W, 3))
        ok = p["valid"] == 1
        self.assertGreater(ok.mean(), 0.95)
        z = p["points"][..., 2][ok]
        self.assertLess(np.abs(np.median(z) - 5.0), 0.05)  # fx * B / d = 50 / 10
        # the plane moves 3 px right, 1 px down at 5 m: 0.15 m, 0.05 m, 0 m
        np.testing.assert_allclose(np.median(p["motion"][ok], axis=0), [0.15, 0.05, 0.0], atol=0.01)
        self.assertTrue(np.isnan(p["points"][~ok]).all())

    def test_holes_are_nan(self):
        # Sparse stage: holes. u, v, d0, d1 and flow are NaN there, confidence 0; valid says where.
        r = run_pair(self.scene, self.lidar, options={"last_stage": "sparse"})
        hole = r["valid"] == 0
        self.assertGreater(hole.mean(), 0.5)
        self.assertGreater((~hole).sum(), 10)
        for name in ("u", "v", "d0", "d1"):
            self.assertTrue(np.isnan(r[name][hole]).all(), name)
            self.assertTrue(np.isfinite(r[name][~hole]).all(), name)
        self.assertTrue(np.isnan(r["flow"][hole]).all())
        self.assertTrue((r["confidence"][hole] == 0).all())

    def test_library_messages_reach_logging(self):
        # Points behind the camera and outside the image are dropped, and the library says so
        # through logging's "lidarflow" logger, naming the frame.
        pts = np.array([[0.0, 0.0, 5.0], [0.1, 0.0, -2.0], [-100.0, 0.0, 5.0], [100.0, 0.0, 5.0]], np.float32)
        with lidarflow.Estimator(options=dict(FAST, last_stage="matching"), **CAL) as est:
            with self.assertLogs("lidarflow", level="INFO") as logs:
                est.push(self.scene[0], self.scene[1], pts, timestamp=41, lidar_kind="camera")
        text = "\n".join(logs.output)
        self.assertIn("3 of 4 LiDAR points dropped", text)
        self.assertIn("frame 41 us", text)

    def test_padded_input_rows_and_colour_orders(self):
        padded = [np.zeros((H, W + 24), np.uint8) for _ in range(4)]
        for p, img in zip(padded, self.scene):
            p[:, :W] = img
        views = [p[:, :W] for p in padded]
        self.assertGreater(views[0].strides[0], W)
        self.assertTrue(same(run_pair(views, self.lidar), self.ref))
        # The same colours as RGB and as BGR give the same result.
        noise = np.random.RandomState(3).randint(0, 256, (4, H, W)).astype(np.uint8)
        rgb = [np.ascontiguousarray(np.stack([g, 255 - g, n], axis=2)) for g, n in zip(self.scene, noise)]
        bgr = [np.ascontiguousarray(c[..., ::-1]) for c in rgb]
        self.assertTrue(same(run_pair(rgb, colour_order="rgb"), run_pair(bgr, color_order="bgr")))
        # A colour frame without an order is refused, with the fix in the message.
        with lidarflow.Estimator(options=FAST, **CAL) as est:
            with self.assertRaises(ValueError) as cm:
                est.push(bgr[0], bgr[1])
            self.assertIn('colour_order="bgr"', str(cm.exception))
            self.assertIn("cv2", str(cm.exception))
            self.assertFalse(est.has_result)


class InputQuality(unittest.TestCase):
    """Estimator.quality() on the scene and on the rig's usual mistakes made from it here (stage 1
    only: the checks run before it)."""

    def quality(self, frames, lidar=None):
        with lidarflow.Estimator(options={"preset": "realtime", "last_stage": "matching"}, **CAL) as est:
            with self.assertRaises(lidarflow.LidarflowError) as e:
                est.quality()
            self.assertEqual(e.exception.status, lidarflow.ERR_NOT_READY)
            est.push(frames[0], frames[1], lidar, timestamp=0)
            est.push(frames[2], frames[3], lidar, timestamp=1)
            return est.quality()

    def setUp(self):
        self.scene = make_scene(width=320, height=96)

    def test_ok(self):
        q = self.quality(self.scene, grid_lidar(10, width=320, height=96))
        self.assertEqual((q.flags, q.states, q.reason, q.ok, str(q)), (0, (), "", True, "ok"))

    def test_swapped(self):
        l0, r0, l1, r1 = self.scene
        q = self.quality((r0, l0, r1, l1))
        self.assertEqual(q.states, ("left_right_swapped",))
        self.assertIn("negative disparity", q.reason)

    def test_black_t1_and_lidar_off(self):
        l0, r0 = self.scene[:2]
        black = np.zeros_like(l0)
        q = self.quality((l0, r0, black, black))
        self.assertEqual(q.states, ("blank_frame",))
        self.assertTrue(str(q).startswith("blank_frame (left1 is black"))
        q = self.quality(self.scene, grid_lidar(16, width=320, height=96))
        self.assertEqual(q.states, ("lidar_disagrees",))
        self.assertEqual(q.flags, 16)


class EgoMotion(unittest.TestCase):
    def test_ego_motion_and_object_motion(self):
        scene = make_scene()
        with lidarflow.Estimator(options=FAST, **CAL) as est:
            with self.assertRaises(lidarflow.LidarflowError) as ctx:
                est.ego_motion()
            self.assertEqual(ctx.exception.status, lidarflow.ERR_NOT_READY)
            est.push(scene[0], scene[1], grid_lidar(10), timestamp=0)
            est.push(scene[2], scene[3], grid_lidar(10), timestamp=1)
            T, inliers = est.ego_motion()
            self.assertEqual(T.shape, (4, 4))
            self.assertEqual(T.dtype, np.float64)
            np.testing.assert_array_equal(T[3], [0, 0, 0, 1])
            self.assertGreater(inliers, 0)
            p, o = est.points3d(), est.object_motion()
            self.assertEqual(o["motion"].shape, (H, W, 3))
            self.assertEqual(o["motion"].dtype, np.float32)
            np.testing.assert_array_equal(o["valid"], p["valid"])
            ok = o["valid"] == 1
            self.assertTrue(np.isnan(o["motion"][~ok]).all())
            x0 = p["points"][ok].astype(np.float64)
            want = x0 + p["motion"][ok] - (x0 @ T[:3, :3].T + T[:3, 3])
            np.testing.assert_allclose(o["motion"][ok], want, atol=1e-4)
            # one rigid plane: everything moves with the camera, nothing on its own
            self.assertGreater((np.linalg.norm(o["motion"][ok], axis=1) < 0.02).mean(), 0.9)

    def test_no_ego_motion_without_stage_4(self):
        scene = make_scene()
        with lidarflow.Estimator(options=dict(FAST, last_stage="sparse"), **CAL) as est:
            est.push(scene[0], scene[1], grid_lidar(10), timestamp=0)
            est.push(scene[2], scene[3], grid_lidar(10), timestamp=1)
            for call in (est.ego_motion, est.object_motion):
                with self.assertRaises(lidarflow.LidarflowError) as ctx:
                    call()
                self.assertEqual(ctx.exception.status, lidarflow.ERR_BAD_STATE)
                self.assertIn("before interpolation", str(ctx.exception))


class BadInput(unittest.TestCase):
    def setUp(self):
        self.scene = make_scene()
        self.est = lidarflow.Estimator(options=FAST, **CAL)

    def tearDown(self):
        self.est.close()

    def assertValueError(self, fragment, fn, *args, **kw):
        with self.assertRaises(ValueError) as cm:
            fn(*args, **kw)
        self.assertIn(fragment, str(cm.exception))

    def assertLidarflowError(self, status, fragment, fn, *args, **kw):
        with self.assertRaises(lidarflow.LidarflowError) as cm:
            fn(*args, **kw)
        self.assertEqual(cm.exception.status, status)
        self.assertIn(fragment, cm.exception.message)

    def test_bad_arrays(self):
        l, r = self.scene[0], self.scene[1]
        push = self.est.push
        self.assertValueError("dtype uint8", push, l.astype(np.float32), r)
        self.assertValueError("numpy array", push, l.tolist(), r)
        self.assertValueError("shape (H, W) or (H, W, 3)", push, l[..., None].repeat(4, 2), r)
        self.assertValueError("shape (H, W) or (H, W, 3)", push, l.ravel(), r)
        self.assertValueError("empty", push, l[:0], r[:0])
        self.assertValueError("packed rows", push, l[:, ::2], r[:, ::2])
        self.assertValueError("packed rows", push, l[:, ::-1], r)
        self.assertValueError("differ in shape", push, l, r[:, :W - 2])
        self.assertValueError("colour_order", push, l, r, colour_order="rgba")
        self.assertValueError("disagree", push, l, r, colour_order="rgb", color_order="bgr")
        lid = grid_lidar(10)
        self.assertValueError("float32", push, l, r, lid.astype(np.float64))
        self.assertValueError("(N, 3)", push, l, r, lid[:, :2])
        self.assertValueError("packed float32", push, l, r, np.asfortranarray(lid))
        self.assertValueError("lidar_kind", push, l, r, lid, lidar_kind="points")
        self.assertFalse(self.est.has_result)

    def test_integers_out_of_range_are_refused_before_ctypes(self):
        # ctypes would wrap them: a width of 2**32 + 64 to 64, threads 2**64 + 2 to 2, a
        # timestamp 2**64 + 5 to 5.
        buf = np.zeros(256, np.uint8)
        wide = np.lib.stride_tricks.as_strided(buf, shape=(1, 2 ** 32 + 64), strides=(2 ** 32 + 64, 1))
        self.assertValueError("each side must be at most 16384", self.est.push, wide, wide)
        tall = np.zeros((16385, 2), np.uint8)
        self.assertValueError("2 x 16385 px", self.est.push, tall, tall)
        l, r = self.scene[0], self.scene[1]
        self.assertValueError("timestamp = 18446744073709551621 is outside int64", self.est.push, l, r,
                              timestamp=2 ** 64 + 5)
        self.assertValueError("outside int64", self.est.push, l, r, timestamp=-2 ** 63 - 1)
        self.assertFalse(self.est.has_result)
        for threads in (2 ** 64 + 2, 2 ** 70, np.uint64(2 ** 63)):
            with self.assertRaises(ValueError) as cm:
                lidarflow.Estimator(options={"threads": threads}, **CAL)
            self.assertIn("option 'threads' = %d is outside int64" % int(threads), str(cm.exception))
        self.assertFalse(self.est.push(l, r, timestamp=2 ** 63 - 1))
        self.assertValueError("no later one", self.est.push, l, r)

    def test_library_errors_leave_the_estimator_usable(self):
        l, r = self.scene[0], self.scene[1]
        lid = grid_lidar(10)
        lid[3, 2] = np.nan
        self.assertLidarflowError(lidarflow.ERR_INVALID_ARGUMENT, "not finite", self.est.push, l, r, lid)
        lid = grid_lidar(10)
        lid[0, 2] = 20000  # an entry off the image would only be dropped (and logged)
        self.assertLidarflowError(lidarflow.ERR_INVALID_ARGUMENT, "disparity outside", self.est.push, l, r, lid)
        self.assertLidarflowError(lidarflow.ERR_INVALID_ARGUMENT, "lidar_to_camera", self.est.push, l, r,
                                  grid_lidar(10), lidar_kind="lidar")
        self.assertLidarflowError(lidarflow.ERR_NOT_READY, "no result yet", self.est.result)
        self.assertFalse(self.est.push(l, r, timestamp=10))
        self.assertLidarflowError(lidarflow.ERR_INVALID_ARGUMENT, "not after", self.est.push, l, r, timestamp=10)
        self.assertLidarflowError(lidarflow.ERR_SIZE_MISMATCH, "previous frame", self.est.push, l[:, :100],
                                  r[:, :100], timestamp=11)
        self.assertTrue(self.est.push(self.scene[2], self.scene[3], timestamp=11))
        self.assertGreater(accuracy(self.est.result()), 0.95)

    def test_bad_out_arrays(self):
        self.est.push(self.scene[0], self.scene[1])
        self.est.push(self.scene[2], self.scene[3])
        self.assertValueError("float32", self.est.result, out={"u": np.zeros((H, W), np.float64)})
        self.assertValueError("shape", self.est.result, out={"u": np.zeros((H, W + 1), np.float32)})
        ro = np.zeros((H, W), np.float32)
        ro.flags.writeable = False
        self.assertValueError("read-only", self.est.result, out={"u": ro})
        self.assertValueError("packed rows", self.est.result, out={"u": np.zeros((H, 2 * W), np.float32)[:, ::2]})
        self.assertValueError("unknown keys", self.est.result, out={"uv": np.zeros((H, W), np.float32)})
        self.assertValueError("(64, 160, 2)", self.est.result, out={"flow": np.zeros((H, W), np.float32)})
        self.assertValueError("dict", self.est.result, out=[np.zeros((H, W), np.float32)])
        self.assertValueError("(64, 160, 3)", self.est.points3d, out={"points": np.zeros((H, W), np.float32)})

    def test_bad_options(self):
        with self.assertRaises(lidarflow.LidarflowError) as cm:
            lidarflow.Estimator(options={"thread": 2}, **CAL)
        self.assertIn("unknown option key 'thread'", cm.exception.message)
        with self.assertRaises(lidarflow.LidarflowError) as cm:
            lidarflow.Estimator(options={"threads": 0}, **CAL)
        self.assertIn("[1, 256]", cm.exception.message)
        self.assertValueError("unsupported value type", lidarflow.Estimator, options={"threads": [2]}, **CAL)
        self.assertValueError("4x4", lidarflow.Estimator, lidar_to_camera=np.eye(3), **CAL)
        with self.assertRaises(lidarflow.LidarflowError) as cm:
            lidarflow.Estimator(100, 100, 80, 32, 0.0)
        self.assertEqual(cm.exception.status, lidarflow.ERR_INVALID_ARGUMENT)


class Presets(unittest.TestCase):
    def test_named_presets_reach_the_library(self):
        # "fast" works at 0.65 resolution: it needs more than 160x64 pixels.
        w, h = 320, 160
        scene, lidar = make_scene(width=w, height=h), grid_lidar(10, width=w, height=h)
        with lidarflow.Estimator(options={"preset": "default"}, **CAL) as est:
            est.push(scene[0], scene[1], lidar)
            est.push(scene[2], scene[3], lidar)
            default = est.result()
        results = {}
        for name in ("paper", "balanced", "fast"):
            with lidarflow.Estimator(options={"preset": name, "threads": 2}, **CAL) as est:
                self.assertFalse(est.push(scene[0], scene[1], lidar))
                self.assertTrue(est.push(scene[2], scene[3], lidar))
                results[name] = est.result()
        self.assertFalse(same(results["fast"], default))  # sparser DIS patches, ternary census
        back = {"preset": "fast", "matching.flow_patch_stride": 2, "stereo.ternary_census": 0,
                "stereo.census_threshold": 0, "threads": 2}
        with lidarflow.Estimator(options=back, **CAL) as est:
            est.push(scene[0], scene[1], lidar)
            est.push(scene[2], scene[3], lidar)
            self.assertTrue(same(est.result(), default))  # and nothing else
        self.assertFalse(same(results["paper"], default))
        self.assertFalse(same(results["balanced"], default))
        for r in results.values():
            self.assertGreater(accuracy(r), 0.9)
        with self.assertRaises(lidarflow.LidarflowError) as cm:
            lidarflow.Estimator(options={"preset": "turbo"}, **CAL)
        self.assertIn("unknown preset 'turbo'", cm.exception.message)


class KittiCalibration(unittest.TestCase):
    def test_reads_files_into_estimator_arguments(self):
        import tempfile
        with tempfile.TemporaryDirectory() as tmp:
            cam, velo = os.path.join(tmp, "cam.txt"), os.path.join(tmp, "velo.txt")
            with open(cam, "w") as f:
                f.write("R_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: 700 0 600 35 0 710 180 0 0 0 1 0\n"
                        "P_rect_03: 700 0 600 -315 0 710 180 0 0 0 1 0\n")
            with open(velo, "w") as f:
                f.write("R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 -0.3\n")
            cal = lidarflow.read_kitti_calibration(cam)
            self.assertIsNone(cal["lidar_to_camera"])
            self.assertAlmostEqual(cal["baseline"], 0.5, places=12)
            cal = lidarflow.read_kitti_calibration(cam, velo)
            self.assertEqual((cal["fx"], cal["fy"], cal["cx"], cal["cy"]), (700, 710, 600, 180))
            # camera 0 -> camera 2 is +0.05 m in x; the Velodyne sits 0.3 m behind camera 0.
            np.testing.assert_allclose(cal["lidar_to_camera"] @ [10, 1, 0, 1], [-0.95, 0, 9.7, 1], atol=1e-12)
            lidarflow.Estimator(**cal).close()
            with self.assertRaises(lidarflow.LidarflowError) as cm:
                lidarflow.read_kitti_calibration(os.path.join(tmp, "missing.txt"))
            self.assertEqual(cm.exception.status, lidarflow.ERR_IO)
            with self.assertRaises(lidarflow.LidarflowError) as cm:
                lidarflow.read_kitti_calibration(cam, cam)
            self.assertEqual(cm.exception.status, lidarflow.ERR_FORMAT)


class OtherCalibrationSources(unittest.TestCase):
    """read_calibration: camera_info pairs with image size, raw rigs rectified by the Estimator,
    and the size check (a warning, or ERR_SIZE_MISMATCH with input.strict)."""

    @staticmethod
    def camera_info(path, tx, d="[0, 0, 0, 0, 0]", cx=80):
        with open(path, "w") as f:
            f.write("image_width: %d\nimage_height: %d\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
                    "  data: [100, 0, %g, 0, 100, 32, 0, 0, 1]\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n"
                    "  data: %s\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
                    "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [100, 0, 80, %g, 0, 100, 32, 0, 0, 0, 1, 0]\n"
                    % (W, H, cx, d, tx))
        return path

    def test_camera_info_pair_and_raw_rig(self):
        import tempfile
        with tempfile.TemporaryDirectory() as tmp:
            left = self.camera_info(os.path.join(tmp, "l.yaml"), 0)
            right = self.camera_info(os.path.join(tmp, "r.yaml"), -50)
            cal = lidarflow.read_calibration(left + "," + right)
            self.assertEqual(cal["image_size"], (W, H))
            self.assertIsNone(cal["raw"])
            self.assertEqual({k: cal[k] for k in CAL}, CAL)
            # The raw right camera's principal point 3 px right of the rectified one: its images
            # are the rectified ones shifted by 3 px (disparity 13 looks like 10).
            shifted = self.camera_info(os.path.join(tmp, "s.yaml"), -50, cx=83)
            raw = lidarflow.read_calibration(left + "," + shifted)
            self.assertEqual(raw["raw"]["right"]["K"][0, 2], 83)
            scene = make_scene(d=10)
            with lidarflow.Estimator(options=FAST, **raw) as est:
                est.push(scene[0], scene[1], timestamp=0)
                est.push(scene[2], scene[3], timestamp=100000)
                self.assertGreater(accuracy(est.result(), d=13), 0.8)
                self.assertTrue(est.info()["rectified"])  # results in the rectified left camera
            with self.assertRaises(lidarflow.LidarflowError) as cm:
                lidarflow.read_calibration(left)
            self.assertEqual(cm.exception.status, lidarflow.ERR_FORMAT)
            self.assertIn(left, cm.exception.message)

    def test_image_size_strict(self):
        small = [a[:, :W - 16] for a in make_scene()]
        with lidarflow.Estimator(options=dict(FAST, **{"input.strict": 1}), image_size=(W, H), **CAL) as est:
            with self.assertRaises(lidarflow.LidarflowError) as cm:
                est.push(small[0], small[1], timestamp=0)
            self.assertEqual(cm.exception.status, lidarflow.ERR_SIZE_MISMATCH)
            self.assertIn("calibration is for %dx%d" % (W, H), cm.exception.message)
        with lidarflow.Estimator(options=FAST, image_size=(W, H), **CAL) as est:
            est.push(small[0], small[1], timestamp=0)  # a warning only
        cal = lidarflow.read_kitti_calibration(KITTI_CAM) if os.path.exists(KITTI_CAM) else None
        if cal is not None:
            self.assertEqual(cal["image_size"], (1242, 375))


class Lifetime(unittest.TestCase):
    def test_double_close_and_context_manager(self):
        est = lidarflow.Estimator(**CAL)
        est.close()
        est.close()
        self.assertTrue(est.closed)
        self.assertRaises(ValueError, est.push, *make_scene()[:2])
        self.assertRaises(ValueError, est.result)
        self.assertRaises(ValueError, est.reset)
        with lidarflow.Estimator(**CAL) as est2:
            self.assertFalse(est2.closed)
        self.assertTrue(est2.closed)
        est2.close()

    def test_finalizer_frees_a_forgotten_handle(self):
        est = lidarflow.Estimator(**CAL)
        fin = est._finalizer
        self.assertTrue(fin.alive)
        del est
        gc.collect()
        self.assertFalse(fin.alive)

    def test_abi_check(self):
        _lib.check_abi(_lib.lib)
        with self.assertRaises(ImportError) as cm:
            _lib.check_abi(_lib.lib, expected=_lib.ABI_MAJOR + 1)
        self.assertIn("needs ABI", str(cm.exception))

    def test_explicit_library_path_must_exist(self):
        env = dict(os.environ, LIDARFLOW_LIBRARY="/nonexistent/liblidarflow.so.0")
        p = subprocess.run([sys.executable, "-c", "import lidarflow"], env=env, capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("ImportError", p.stderr)
        self.assertIn("/nonexistent/liblidarflow.so.0", p.stderr)


class Threads(unittest.TestCase):
    def test_frames_in_flight_hand_results_over_late_and_equal_single_pairs(self):
        # A drive past the plane: frame k is the texture shifted by k * 3 px. Nothing moves on
        # its own, so the pairs have no motion prior and equal the single pairs.
        scene = make_scene(tu=3, tv=0)
        frames = [(scene[0], scene[1]), (scene[2], scene[3])]
        frames += [(np.roll(f[0], 3 * k, axis=1), np.roll(f[1], 3 * k, axis=1)) for k in (1, 2) for f in frames[:1]]
        lidar = grid_lidar(10)
        single = []
        for k in range(len(frames) - 1):
            with lidarflow.Estimator(options=dict(FAST, threads=2), **CAL) as est:
                est.push(*frames[k], lidar, timestamp=k)
                est.push(*frames[k + 1], lidar, timestamp=k + 1)
                single.append(est.result())
        handed = []
        with lidarflow.Estimator(options=dict(FAST, threads=2, frames_in_flight=2), **CAL) as est:
            self.assertIsNone(est.flush())  # nothing in flight yet
            for k, f in enumerate(frames):
                if est.push(*f, lidar, timestamp=k):  # pair k - 2 comes with frame k
                    self.assertEqual(est.info()["t1_us"], k - 1)
                    handed.append(est.result())
            while est.flush() is not None:
                handed.append(est.result())
        self.assertEqual(len(handed), len(single))
        for k in range(len(single)):
            self.assertTrue(same(handed[k], single[k]), "pair %d differs" % k)

    def test_a_log_handler_on_a_frame_worker_is_refused_not_blocked(self):
        # The same frame three times: each frozen pair's input check warns from the frame worker
        # that computes it, while the owner's push or flush may be waiting for that pair.
        scene = make_scene()
        owner = threading.get_ident()
        outcomes = []

        class Reenter(logging.Handler):
            def emit(self, record):
                if threading.get_ident() == owner:
                    return
                try:
                    est.flush()
                    outcomes.append("returned")
                except lidarflow.LidarflowError as e:
                    outcomes.append(e.status)

        logger = logging.getLogger("lidarflow")
        handler, level = Reenter(logging.WARNING), logger.level
        logger.addHandler(handler)
        logger.setLevel(logging.WARNING)
        try:
            with lidarflow.Estimator(options=dict(FAST, threads=2, frames_in_flight=2), **CAL) as est:
                for t in range(3):
                    est.push(scene[0], scene[1], timestamp=t)
                while est.flush() is not None:
                    pass
        finally:
            logger.removeHandler(handler)
            logger.setLevel(level)
        self.assertTrue(outcomes)
        self.assertEqual(set(outcomes), {lidarflow.ERR_BAD_STATE})

    def test_n_handles_in_n_threads_match_serial_runs(self):
        cases = [(make_scene(seed=s, tu=tu, tv=tv), grid_lidar(10)) for s, tu, tv in ((1, 3, 1), (2, -2, 0), (3, 1, 2))]
        serial = [run_pair(scene, lidar) for scene, lidar in cases]
        parallel = [None] * len(cases)
        errors = []

        def work(k):
            try:
                parallel[k] = run_pair(*cases[k])
            except Exception as e:  # surfaced below: a thread's exception would be lost
                errors.append(e)

        threads = [threading.Thread(target=work, args=(k,)) for k in range(len(cases))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertEqual(errors, [])
        for k in range(len(cases)):
            self.assertTrue(same(parallel[k], serial[k]), "case %d differs" % k)
        self.assertFalse(same(serial[0], serial[1]))  # the cases are distinct

    def test_default_timestamps_from_two_threads(self):
        # timestamp=None is the previous frame's + 1, taken under the Estimator's lock: no push
        # may be refused as "not after the previous frame's".
        scene = make_scene()
        errors = []
        with lidarflow.Estimator(options=dict(FAST, threads=1), **CAL) as est:
            def work(k):
                for i in range(10):
                    try:
                        est.push(scene[2 * ((i + k) % 2)], scene[2 * ((i + k) % 2) + 1])
                    except Exception as e:
                        errors.append(e)

            threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            self.assertEqual(errors, [])
            self.assertEqual(est.info()["t1_us"], 19)


if __name__ == "__main__":
    unittest.main()
