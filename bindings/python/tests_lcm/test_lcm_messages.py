# SPDX-License-Identifier: MIT
"""lidarflow_lcm's codecs (CTest: python_lcm): fingerprints and bytes against the Python code
lcm-gen generates from lcm_types/*.lcm (an independent encoder/decoder, loaded under another
package name), round trips, and refusal of malformed messages."""
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import tempfile
import unittest
import warnings

import numpy as np

import lidarflow_lcm as ll
from lidarflow_lcm import messages

HERE = os.path.dirname(os.path.abspath(__file__))
LCM_TYPES = os.path.join(HERE, "..", "..", "..", "lcm_types")


def random_message(cls, rng, n=None):
    """A message of `cls` with random field values and consistent lengths (check() passes)."""
    if cls is ll.stereo_t:
        h, w = int(rng.integers(1, 9)), int(rng.integers(1, 9))
        fmt = int(rng.integers(1, 4))
        stride = w * ll.stereo_t.BYTES_PER_PIXEL[fmt] + int(rng.integers(0, 3))
        size = stride * h
        return ll.stereo_t(utime=int(rng.integers(-2**63, 2**63 - 1)), sequence=int(rng.integers(-2**31, 2**31 - 1)),
                           frame_number=int(rng.integers(0, 2**62)), width=w, height=h, row_stride=stride,
                           pixel_format=fmt, size=size, left=rng.bytes(size), right=rng.bytes(size))
    if cls is ll.lidar_t:
        n = int(rng.integers(0, 7)) if n is None else n
        transform = rng.normal(size=16)
        transform[12:] = [0, 0, 0, 1]  # a rigid transform's last row, as the bridge requires
        return ll.lidar_t(utime=int(rng.integers(0, 2**62)), frame=int(rng.integers(1, 4)),
                          lidar_to_camera=transform, num_points=n,
                          x=rng.normal(size=n).astype(np.float32), y=rng.normal(size=n).astype(np.float32),
                          z=rng.normal(size=n).astype(np.float32))
    if cls is ll.calibration_t:
        return ll.calibration_t(utime=int(rng.integers(0, 2**62)), width=int(rng.integers(0, 2000)),
                                height=int(rng.integers(0, 2000)), fx=float(rng.uniform(1, 1e3)),
                                fy=float(rng.uniform(1, 1e3)), cx=float(rng.normal()), cy=float(rng.normal()),
                                baseline=float(rng.uniform(0.01, 1)))
    if cls is ll.scene_flow_t:
        iw, ih, step = int(rng.integers(1, 12)), int(rng.integers(1, 12)), int(rng.integers(1, 4))
        w, h = -(-iw // step), -(-ih // step)
        enc = int(rng.integers(1, 3))
        ps = w * h * (4 if enc == 1 else 2)
        return ll.scene_flow_t(utime=int(rng.integers(0, 2**62)), utime0=int(rng.integers(0, 2**62)),
                               sequence=int(rng.integers(0, 100)), lidar_flags=int(rng.integers(0, 4)),
                               lidar_utime0=int(rng.integers(0, 2**62)), lidar_utime1=int(rng.integers(0, 2**62)),
                               last_stage=int(rng.integers(1, 5)), image_width=iw, image_height=ih, step=step,
                               width=w, height=h, encoding=enc, scale=1.0 if enc == 1 else 1 / 64,
                               compute_seconds=float(np.float32(rng.uniform())), plane_size=ps, valid_size=w * h,
                               u=rng.bytes(ps), v=rng.bytes(ps), d0=rng.bytes(ps), d1=rng.bytes(ps),
                               valid=bytes(rng.integers(0, 2, w * h, dtype=np.uint8)))
    if cls is ll.status_t:
        m = ll.status_t()
        for name, typ, _ in m._FIELDS:
            if typ == "int64_t":
                setattr(m, name, int(rng.integers(0, 2**62)))
            elif typ == "int32_t":
                setattr(m, name, int(rng.integers(0, 2**31 - 1)))
            elif typ == "int8_t":
                setattr(m, name, int(rng.integers(0, 2)))
            elif typ in ("float", "double"):
                setattr(m, name, float(np.float32(rng.uniform(0, 100))))
        m.last_error = "".join(chr(int(c)) for c in rng.integers(32, 0x3000, int(rng.integers(0, 20))))
        return m
    if cls is ll.ego_motion_t:
        q, r = np.linalg.qr(rng.normal(size=(3, 3)))
        R = q * np.sign(np.diag(r))
        if np.linalg.det(R) < 0:
            R[:, 0] = -R[:, 0]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, rng.normal(size=3)
        c = int(rng.integers(0, 10**6))
        return ll.ego_motion_t(utime=int(rng.integers(0, 2**62)), utime0=int(rng.integers(0, 2**62)),
                               sequence=int(rng.integers(0, 100)), state=0, transform=T.ravel(),
                               inliers=int(rng.integers(0, c + 1)), candidates=c)
    if cls is ll.quality_t:
        flags = int(rng.integers(0, 32))
        reason = "".join(chr(int(c)) for c in rng.integers(32, 0x3000, int(rng.integers(1, 40)))) if flags else ""
        return ll.quality_t(utime=int(rng.integers(0, 2**62)), utime0=int(rng.integers(0, 2**62)),
                            sequence=int(rng.integers(0, 100)), flags=flags, reason=reason)
    raise AssertionError(cls)


def load_lcm_gen_python(out_dir):
    """lcm-gen -p's classes for lcm_types/*.lcm, imported as package `lcmgen_lidarflow` (their
    own package name, lidarflow, is the binding's)."""
    lcm_gen = os.environ.get("LCM_GEN") or shutil.which("lcm-gen")
    if not lcm_gen:
        raise unittest.SkipTest("no lcm-gen (apt-get install liblcm-bin)")
    defs = [os.path.join(LCM_TYPES, t.TYPE_NAME.split(".")[1] + ".lcm") for t in ll.TYPES]
    subprocess.run([lcm_gen, "-p", "--ppath", out_dir] + defs, check=True)
    pkg = os.path.join(out_dir, "lidarflow")
    spec = importlib.util.spec_from_file_location("lcmgen_lidarflow", os.path.join(pkg, "__init__.py"),
                                                  submodule_search_locations=[pkg])
    module = importlib.util.module_from_spec(spec)
    sys.modules["lcmgen_lidarflow"] = module
    spec.loader.exec_module(module)
    return module


class AgainstLcmGen(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.gen = load_lcm_gen_python(cls.tmp.name)

    @classmethod
    def tearDownClass(cls):
        sys.modules.pop("lcmgen_lidarflow", None)
        cls.tmp.cleanup()

    def generated(self, cls):
        return getattr(self.gen, cls.TYPE_NAME.split(".")[1])

    def test_fingerprints_equal_lcm_gen(self):
        for cls in ll.TYPES:
            self.assertEqual(cls._get_packed_fingerprint(), self.generated(cls)._get_packed_fingerprint(), cls.TYPE_NAME)
        self.assertEqual(len({cls.FINGERPRINT for cls in ll.TYPES}), 7)

    def test_bytes_equal_lcm_gen_both_ways(self):
        rng = np.random.default_rng(11)
        for cls in ll.TYPES:
            gen = self.generated(cls)
            for _ in range(30):
                ours = random_message(cls, rng)
                raw = ours.encode()
                theirs = gen.decode(raw)  # lcm-gen reads ours ...
                self.assertEqual(theirs.encode(), raw, cls.TYPE_NAME)  # ... and writes the same bytes
                back = cls.decode(theirs.encode())
                self.assertEqual(back, ours, cls.TYPE_NAME)
                for name, typ, dim in cls._FIELDS:
                    if dim is None and typ not in ("float", "double"):
                        self.assertEqual(getattr(theirs, name), getattr(back, name), name)

    def test_lcm_gen_field_layout_is_ours(self):
        # The slots lcm-gen emits are the .lcm members in order: a field added to a .lcm file and
        # not here fails this even before the fingerprint test.
        for cls in ll.TYPES:
            self.assertEqual(list(self.generated(cls).__slots__), [f[0] for f in cls._FIELDS], cls.TYPE_NAME)


class RoundTrip(unittest.TestCase):
    def test_every_type(self):
        rng = np.random.default_rng(5)
        for cls in ll.TYPES:
            for _ in range(50):
                m = random_message(cls, rng)
                raw = m.encode()
                self.assertIs(ll.type_of(raw), cls)
                self.assertEqual(cls.decode(raw), m)
                self.assertEqual(ll.decode(raw).encode(), raw)

    def test_signalling_nans_round_trip_exactly(self):
        # Python floats are doubles: a float32 signalling NaN converted to one and back comes
        # back quiet (another bit pattern). Scalar float fields keep their bytes.
        flow = random_message(ll.scene_flow_t, np.random.default_rng(5))
        flow.encoding, flow.scale = ll.scene_flow_t.ENCODING_FLOAT32, 1.0
        flow.plane_size = flow.width * flow.height * 4
        for k in ("u", "v", "d0", "d1"):
            setattr(flow, k, bytes(flow.plane_size))
        status = ll.status_t()
        for msg, fields in ((flow, (("scale", "7f800001"), ("compute_seconds", "ffa00005"))),
                            (status, (("latency_mean_ms", "7f800123"), ("compute_last_ms", "ff800001"),
                                      ("uptime_seconds", "7ff0000000000001")))):
            # The NaN bit patterns put on the wire directly.
            raw = bytearray(msg.encode())
            offset = 8
            for name, typ, dim in type(msg)._FIELDS:
                size = messages.struct.calcsize(messages._PRIMITIVES[typ][0]) if dim is None and typ != "string" else None
                for field, bits in fields:
                    if name == field:
                        raw[offset:offset + size] = bytes.fromhex(bits)
                if size is None:
                    break  # the fields set here all come before the first array or string
                offset += size
            raw = bytes(raw)
            decoded = type(msg).decode(raw)
            for field, _ in fields:
                self.assertTrue(math.isnan(getattr(decoded, field)), field)
            self.assertEqual(decoded.encode(), raw, type(msg).TYPE_NAME)
            self.assertEqual(type(msg).decode(decoded.encode()), decoded)

    def test_defaults_encode(self):
        # An empty status is consistent; an empty calibration is not a camera (fx 0), which the
        # bridge refuses, but it round-trips unchecked.
        self.assertEqual(ll.status_t.decode(ll.status_t().encode()), ll.status_t())
        with self.assertRaisesRegex(ll.MessageError, "fx, fy, baseline must be > 0"):
            ll.calibration_t().encode()
        cal = ll.calibration_t()
        self.assertEqual(ll.calibration_t.decode(cal.encode(check=False), check=False), cal)

    def test_unknown_field_refused(self):
        with self.assertRaises(TypeError):
            ll.calibration_t(focal=1.0)

    def test_encode_refuses_inconsistent_arrays(self):
        m = random_message(ll.lidar_t, np.random.default_rng(1), n=3)
        m.num_points = 4
        with self.assertRaisesRegex(ll.MessageError, "x has 3 entries, num_points says 4"):
            m.encode()
        m = random_message(ll.scene_flow_t, np.random.default_rng(2))
        m.u = m.u[:-1]
        with self.assertRaisesRegex(ll.MessageError, "u has"):
            m.encode()
        m = ll.calibration_t(width=2**31)
        with self.assertRaisesRegex(ll.MessageError, "calibration_t"):
            m.encode(check=False)
        with self.assertRaisesRegex(ll.MessageError, "NUL"):
            ll.status_t(last_error="a\0b").encode()


class Malformed(unittest.TestCase):
    """Every kind of bad input is a MessageError with a reason, never a result."""

    def samples(self):
        rng = np.random.default_rng(3)
        return [random_message(cls, rng) for cls in ll.TYPES for _ in range(3)]

    def test_every_truncation_and_extension(self):
        for m in self.samples():
            raw = m.encode()
            for n in range(len(raw)):
                with self.assertRaisesRegex(ll.MessageError, "truncated|wrong size", msg="%s[:%d]" % (m.TYPE_NAME, n)):
                    type(m).decode(raw[:n])
            with self.assertRaisesRegex(ll.MessageError, "wrong size: %d bytes" % (len(raw) + 1)):
                type(m).decode(raw + b"\0")

    def test_wrong_fingerprint_names_the_type(self):
        raw = random_message(ll.calibration_t, np.random.default_rng(0)).encode()
        with self.assertRaisesRegex(ll.MessageError, "bad fingerprint .* this is a lidarflow.calibration_t"):
            ll.scene_flow_t.decode(raw)
        with self.assertRaisesRegex(ll.MessageError, "unknown fingerprint"):
            ll.decode(b"\1" * 8 + raw[8:])

    def test_negative_lengths(self):
        for cls, field in ((ll.stereo_t, "size"), (ll.lidar_t, "num_points"), (ll.scene_flow_t, "plane_size"),
                           (ll.scene_flow_t, "valid_size")):
            raw = self.with_field(random_message(cls, np.random.default_rng(4)), field, -1)
            with self.assertRaisesRegex(ll.MessageError, "negative length %s = -1" % field):
                cls.decode(raw)
        raw = bytearray(ll.status_t().encode())
        raw[-5:-1] = (-3).to_bytes(4, "big", signed=True)
        with self.assertRaisesRegex(ll.MessageError, "string length -3"):
            ll.status_t.decode(bytes(raw))

    @staticmethod
    def with_field(m, field, value):
        """m's bytes with one scalar replaced on the wire (arrays as they are)."""
        offset = 8
        for name, typ, dim in m._FIELDS:
            if name == field:
                code = messages._PRIMITIVES[typ][0]
                raw = bytearray(m.encode(check=False))
                raw[offset:offset + messages.struct.calcsize(code)] = messages.struct.pack(">" + code, value)
                return bytes(raw)
            if isinstance(dim, str):
                raise AssertionError("field %s comes after a variable array" % field)
            offset += messages.struct.calcsize(messages._PRIMITIVES[typ][0]) * (dim or 1)
        raise AssertionError(field)

    def test_lengths_inconsistent_with_the_message_size(self):
        m = random_message(ll.lidar_t, np.random.default_rng(6), n=4)
        for n in (3, 5, 2**31 - 1):
            with self.assertRaisesRegex(ll.MessageError, "truncated|wrong size"):
                ll.lidar_t.decode(self.with_field(m, "num_points", n))

    def test_consistent_wire_but_inconsistent_fields(self):
        rng = np.random.default_rng(7)
        flow = ll.scene_flow_message(*(rng.normal(size=(6, 10)) for _ in range(4)), np.ones((6, 10)), step=2)
        cases = [("encoding", 3, "unknown encoding 3"), ("step", 3, "subsampled by 3"), ("step", 0, "step 0"),
                 ("width", 4, "planes 4x3"), ("image_width", 0, "image 0x6"), ("scale", float("nan"), "scale nan"),
                 ("scale", -1.0, "scale -1")]
        for field, value, reason in cases:
            with self.assertRaisesRegex(ll.MessageError, reason, msg=field):
                ll.scene_flow_t.decode(self.with_field(flow, field, value))
        # plane_size of a float32 plane with the int16 encoding: sizes agree on the wire only.
        f32 = ll.scene_flow_message(*(rng.normal(size=(6, 10)) for _ in range(4)), np.ones((6, 10)), encoding="float32")
        with self.assertRaisesRegex(ll.MessageError, "plane_size 240"):
            ll.scene_flow_t.decode(self.with_field(f32, "encoding", 2))
        raw = bytearray(flow.encode())
        raw[-1] = 2
        with self.assertRaisesRegex(ll.MessageError, r"valid\[14\] = 2"):
            ll.scene_flow_t.decode(bytes(raw))
        stereo = ll.stereo_message(np.zeros((4, 5), np.uint8), np.zeros((4, 5), np.uint8), utime=1)
        for field, value, reason in (("pixel_format", 4, "pixel_format 4"), ("row_stride", 4, "row_stride 4 < width 5"),
                                     ("width", 0, "0x4"), ("height", 5, "size 20 != row_stride 5 x height 5")):
            with self.assertRaisesRegex(ll.MessageError, reason, msg=field):
                ll.stereo_t.decode(self.with_field(stereo, field, value))
        lidar = ll.lidar_message(np.zeros((2, 3)), utime=1)
        with self.assertRaisesRegex(ll.MessageError, "unknown frame 0"):
            ll.lidar_t.decode(self.with_field(lidar, "frame", 0))
        with self.assertRaisesRegex(ll.MessageError, "image size -1x0"):
            ll.calibration_t.decode(self.with_field(ll.calibration_message(100, 100, 50, 20, 0.5), "width", -1))
        raw = bytearray(ll.status_t(last_error="abc").encode())
        raw[-1] = ord("x")
        with self.assertRaisesRegex(ll.MessageError, "not NUL-terminated"):
            ll.status_t.decode(bytes(raw))

    # A signalling NaN among the points is refused without a numpy RuntimeWarning on the way
    # (found by fuzz_lcm.py, which takes any warning for a finding).
    def test_signalling_nan_point_refused_without_warning(self):
        raw = bytearray(ll.lidar_message(np.array([[1, 2, 3]], np.float32), utime=1).encode())
        at = bytes(raw).find(bytes.fromhex("3f800000"))  # x = 1.0f, big-endian
        raw[at:at + 4] = bytes.fromhex("7f800001")
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with self.assertRaisesRegex(ll.MessageError, "point 0 is not finite"):
                ll.decode(bytes(raw))

    def test_random_corruption_is_an_error_or_a_faithful_message(self):
        # Flipped bytes either fail with MessageError or give a message that encodes back to
        # exactly the corrupted bytes (the corruption hit a value, not the structure).
        rng = np.random.default_rng(8)
        outcomes = {"refused": 0, "decoded": 0}
        for m in self.samples():
            raw = m.encode()
            for _ in range(300):
                bad = bytearray(raw)
                for i in rng.integers(0, len(bad), int(rng.integers(1, 4))):
                    bad[i] = int(rng.integers(0, 256))
                try:
                    got = type(m).decode(bytes(bad))
                except ll.MessageError:
                    outcomes["refused"] += 1
                    continue
                outcomes["decoded"] += 1
                self.assertEqual(got.encode(), bytes(bad))
        self.assertGreater(outcomes["refused"], 100)
        self.assertGreater(outcomes["decoded"], 100)


class FlowArrays(unittest.TestCase):
    def planes(self, h=7, w=9, seed=0):
        rng = np.random.default_rng(seed)
        u, v, d0, d1 = (rng.uniform(-50, 50, (h, w)).astype(np.float32) for _ in range(4))
        valid = rng.integers(0, 2, (h, w)).astype(np.uint8)
        return u, v, d0, d1, valid

    def test_float32_step1_is_exact(self):
        u, v, d0, d1, valid = self.planes()
        m = ll.scene_flow_t.decode(ll.scene_flow_message(u, v, d0, d1, valid, encoding="float32").encode())
        a = ll.flow_arrays(m)
        for name, plane in (("u", u), ("v", v), ("d0", d0), ("d1", d1)):
            self.assertEqual(a[name].dtype, np.float32)
            np.testing.assert_array_equal(a[name][valid == 1], plane[valid == 1])
            self.assertTrue(np.isnan(a[name][valid == 0]).all())
        np.testing.assert_array_equal(a["valid"], valid == 1)
        self.assertEqual(a["valid"].dtype, bool)
        # flow: (H, W, 2) float32 as lidarflow.Estimator.result() gives it, NaN holes.
        self.assertEqual((a["flow"].shape, a["flow"].dtype), (u.shape + (2,), np.float32))
        np.testing.assert_array_equal(a["flow"][..., 0], a["u"])
        np.testing.assert_array_equal(a["flow"][..., 1], a["v"])

    def test_int16_quantises_saturates_and_subsamples(self):
        u, v, d0, d1, valid = self.planes(h=9, w=11, seed=1)
        u[0, 0], u[0, 2], u[2, 0] = 600.0, -600.0, 1.0 / 128  # saturate, saturate, half a unit: even -> 0
        u[2, 2] = 3.0 / 128  # 1.5 units: half to even -> 2 units
        valid[:] = 1
        m = ll.scene_flow_t.decode(ll.scene_flow_message(u, v, d0, d1, valid, step=2).encode())
        self.assertEqual((m.width, m.height, m.step, m.image_width, m.image_height), (6, 5, 2, 11, 9))
        a = ll.flow_arrays(m)
        self.assertEqual(a["u"].shape, (5, 6))
        self.assertEqual(a["u"][0, 0], np.float32(32767 / 64))
        self.assertEqual(a["u"][0, 1], np.float32(-32767 / 64))
        self.assertEqual(a["u"][1, 0], 0.0)
        self.assertEqual(a["u"][1, 1], np.float32(2 / 64))
        inside = np.abs(u[::2, ::2]) < 500
        self.assertLessEqual(np.abs(a["u"] - u[::2, ::2])[inside].max(), 1 / 128)
        self.assertLessEqual(np.abs(a["d1"] - d1[::2, ::2]).max(), 1 / 128)
        xs, ys = ll.pixel_grid(m)
        self.assertEqual((xs[3, 5], ys[3, 5]), (10, 6))

    # A huge int16 scale overflows float32 to inf, as in the bridge's decoder, without numpy's
    # RuntimeWarning (found by fuzz_lcm.py).
    def test_int16_scale_overflow_is_inf_without_warning(self):
        m = ll.scene_flow_message(*([np.full((1, 2), 3.0, np.float32)] * 4), np.ones((1, 2), bool), encoding="int16")
        m.scale = 1e38
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            a = ll.flow_arrays(ll.scene_flow_t.decode(m.encode()))
        self.assertTrue(np.all(np.isinf(a["u"])))

    def test_inconsistent_message_refused(self):
        m = ll.scene_flow_message(*self.planes())
        m.valid_size += 1
        with self.assertRaises(ll.MessageError):
            ll.flow_arrays(m)


class Points3d(unittest.TestCase):
    CAL = dict(fx=200.0, fy=180.0, cx=40.5, cy=20.25, baseline=0.5)

    def test_formula_and_validity(self):
        h, w = 6, 8
        u = np.full((h, w), 2.5, np.float32)
        v = np.full((h, w), -1.0, np.float32)
        d0 = np.full((h, w), 10.0, np.float32)
        d1 = np.full((h, w), 8.0, np.float32)
        valid = np.ones((h, w), np.uint8)
        d0[1, 1], d1[2, 2], valid[3, 3] = 0.0, -1.0, 0
        m = ll.scene_flow_message(u, v, d0, d1, valid, encoding="float32", step=2)
        cal = ll.calibration_message(utime=0, width=w, height=h, **self.CAL)
        p = ll.points3d(m, cal)
        self.assertEqual(p["points"].shape, (3, 4, 3))
        # plane (1, 2) is image (x 4, y 2): Z0 = 200 * 0.5 / 10 = 10, Z1 = 12.5
        np.testing.assert_allclose(p["points"][1, 2], [(4 - 40.5) * 10 / 200, (2 - 20.25) * 10 / 180, 10], rtol=1e-6)
        np.testing.assert_allclose(p["points1"][1, 2], [(6.5 - 40.5) * 12.5 / 200, (1 - 20.25) * 12.5 / 180, 12.5],
                                   rtol=1e-6)
        np.testing.assert_allclose(p["motion"][1, 2], p["points1"][1, 2] - p["points"][1, 2], rtol=1e-5)
        expect_invalid = {(1, 1)}  # image (2, 2): d1 < 0; (1, 1) and (3, 3) are not sampled
        for i in range(3):
            for j in range(4):
                self.assertEqual(bool(p["valid"][i, j]), (i, j) not in expect_invalid, (i, j))
        self.assertTrue(np.isnan(p["points"][1, 1]).all())
        # keyword calibration, a mapping and a calibration_t agree
        for other in (ll.points3d(m, **self.CAL), ll.points3d(m, dict(self.CAL))):
            for k in ("points", "points1", "motion"):
                np.testing.assert_array_equal(other[k], p[k])

    def test_calibration_checks(self):
        m = ll.scene_flow_message(*(np.ones((4, 6), np.float32) for _ in range(5)))
        with self.assertRaisesRegex(ValueError, "for 7x4 images, the scene flow for 6x4"):
            ll.points3d(m, ll.calibration_message(width=7, height=4, **self.CAL))
        with self.assertRaisesRegex(ValueError, "lacks baseline"):
            ll.points3d(m, fx=1, fy=1, cx=0, cy=0)
        with self.assertRaisesRegex(ValueError, "baseline > 0"):
            ll.points3d(m, dict(self.CAL, baseline=0))
        self.assertTrue(math.isfinite(ll.points3d(m, **self.CAL)["points"][0, 0, 2]))


class Builders(unittest.TestCase):
    def test_stereo(self):
        rng = np.random.default_rng(9)
        left, right = rng.integers(0, 256, (2, 5, 7, 3), dtype=np.uint8)
        m = ll.stereo_t.decode(ll.stereo_message(left, right, utime=7, frame_number=3, colour_order="bgr").encode())
        self.assertEqual((m.width, m.height, m.row_stride, m.pixel_format, m.frame_number), (7, 5, 21, 3, 3))
        l2, r2, order = ll.stereo_images(m)
        self.assertEqual(order, "bgr")
        np.testing.assert_array_equal(l2, left)
        np.testing.assert_array_equal(r2, right)
        with self.assertRaisesRegex(ValueError, "colour_order"):
            ll.stereo_message(left, right, utime=0)
        with self.assertRaisesRegex(ValueError, "uint8"):
            ll.stereo_message(left.astype(np.int16), right, utime=0, colour_order="rgb")
        # padded rows (another publisher's layout) are cut off
        padded = ll.stereo_t(width=3, height=2, row_stride=5, pixel_format=1, size=10, left=bytes(range(10)),
                             right=bytes(range(10, 20)))
        left, right, order = ll.stereo_images(padded)
        np.testing.assert_array_equal(left, [[0, 1, 2], [5, 6, 7]])
        np.testing.assert_array_equal(right, [[10, 11, 12], [15, 16, 17]])
        self.assertIsNone(order)

    def test_decoders_refuse_what_the_bridge_refuses(self):
        # bridge/wire.cpp's checks and the C ABI's camera ranges (the bridge probes lf_create).
        cal = ll.calibration_message(100, 100, 50, 20, 0.5)
        for field, value, reason in (("fx", float("nan"), "fx = nan is not finite"),
                                     ("cy", float("inf"), "cy = inf is not finite"),
                                     ("baseline", -0.5, "baseline must be > 0"), ("fy", 0.0, "must be > 0"),
                                     ("fx", 1e200, r"fx = 1e\+200 px is outside \[1, 1e\+06\]"),
                                     ("baseline", 1e-300, "baseline = 1e-300 m is outside")):
            with self.assertRaisesRegex(ll.MessageError, reason, msg=field):
                ll.calibration_t.decode(Malformed.with_field(cal, field, value))
        pts = np.array([[1, 2, 3], [4, 5, 6]], np.float32)
        nan_point = ll.lidar_message(pts, utime=1, frame="camera")
        nan_point.y[1] = np.nan
        with self.assertRaisesRegex(ll.MessageError, "point 1 is not finite"):
            ll.lidar_t.decode(nan_point.encode(check=False))
        t = np.eye(4)
        for k, v, reason in ((3, np.inf, r"lidar_to_camera\[3\] is not finite"),
                             (0, np.nan, r"lidar_to_camera\[0\] is not finite"), (14, 1.0, "last row"),
                             (0, 1e300, "point 0 is out of float range")):
            bad = ll.lidar_message(pts, utime=1, frame="lidar", lidar_to_camera=t.copy())
            bad.lidar_to_camera[k] = v
            with self.assertRaisesRegex(ll.MessageError, reason, msg=reason):
                ll.lidar_t.decode(bad.encode(check=False))
        # The transform is not used (nor checked, as in the bridge) for the other frames.
        unused = ll.lidar_message(pts, utime=1, frame="camera")
        unused.lidar_to_camera[3] = np.inf
        self.assertEqual(ll.lidar_t.decode(unused.encode()).frame, ll.lidar_t.FRAME_CAMERA)

    def test_ego_motion_rules(self):
        # bridge/wire.cpp decode_ego_motion's checks, in its order.
        c, s = np.cos(0.1), np.sin(0.1)
        T = np.array([[c, 0, s, 0.1], [0, 1, 0, 0], [-s, 0, c, -0.8], [0, 0, 0, 1]])
        good = ll.ego_motion_t(utime=2, utime0=1, state=0, transform=T.ravel(), inliers=5, candidates=9)
        self.assertEqual(ll.ego_motion_t.decode(good.encode()), good)
        np.testing.assert_array_equal(ll.ego_motion_t.decode(good.encode()).matrix(), T)
        self.assertEqual(ll.ego_motion_t.decode(ll.ego_motion_t(state=1).encode()).state, 1)  # identity default
        cases = [({"state": 5}, "unknown state 5"), ({"state": -1}, "unknown state -1"),
                 ({"inliers": 10}, "inliers 10, candidates 9"), ({"candidates": -1}, "candidates -1"),
                 ({"state": 3}, "state 3 .*identity")]
        for k, v, reason in ((3, np.nan, r"transform\[3\] is not finite"), (11, np.inf, r"transform\[11\] is not"),
                             (12, 0.5, "last row"), (1, 0.5, "not orthonormal")):
            bad = T.copy().ravel()
            bad[k] = v
            cases.append(({"transform": bad}, reason))
        mirror = T.copy()
        mirror[:3, 0] *= -1
        cases.append(({"transform": mirror.ravel()}, "determinant -1"))
        for change, reason in cases:
            m = ll.ego_motion_t(**dict(dict(utime=2, utime0=1, state=0, transform=T.ravel(), inliers=5, candidates=9),
                                       **change))
            with self.assertRaisesRegex(ll.MessageError, reason, msg=reason):
                ll.ego_motion_t.decode(m.encode(check=False))

    def test_quality_rules(self):
        good = ll.quality_t(utime=2, utime0=1, sequence=3, flags=ll.quality_t.FLAG_LEFT_RIGHT_SWAPPED | 16,
                            reason="a; b")
        back = ll.quality_t.decode(good.encode())
        self.assertEqual(back, good)
        self.assertEqual(back.states(), ("left_right_swapped", "lidar_disagrees"))
        self.assertEqual(ll.quality_t.decode(ll.quality_t().encode()).states(), ())  # ok
        for change, reason in (({"flags": 32}, "unknown flags 0x20"), ({"flags": -1}, "unknown flags 0xffffffff"),
                               ({"reason": ""}, "a reason exactly when"), ({"flags": 0}, "a reason exactly when")):
            m = ll.quality_t(**dict(dict(utime=2, utime0=1, flags=8, reason="x"), **change))
            with self.assertRaisesRegex(ll.MessageError, reason, msg=reason):
                ll.quality_t.decode(m.encode(check=False))

    def test_lidar(self):
        pts = np.array([[1, 2, 3], [4, 5, 6]], np.float32)
        for frame, kind in (("disparity", "disparity"), ("camera", "camera")):
            got, k = ll.lidar_points(ll.lidar_t.decode(ll.lidar_message(pts, utime=1, frame=frame).encode()))
            np.testing.assert_array_equal(got, pts)
            self.assertEqual(k, kind)
        t = np.eye(4)
        t[:3, 3] = [0.5, -1, 2]
        t[:3, :3] = [[0, -1, 0], [0, 0, -1], [1, 0, 0]]
        got, k = ll.lidar_points(ll.lidar_message(pts, utime=1, frame="lidar", lidar_to_camera=t))
        np.testing.assert_array_equal(got, (pts.astype(np.float64) @ t[:3, :3].T + t[:3, 3]).astype(np.float32))
        self.assertEqual(k, "camera")
        bad = ll.lidar_message(pts, utime=1, frame="lidar", lidar_to_camera=t)
        bad.lidar_to_camera[15] = 2
        with self.assertRaisesRegex(ll.MessageError, "last row"):
            ll.lidar_points(bad)
        with self.assertRaisesRegex(ValueError, "needs lidar_to_camera"):
            ll.lidar_message(pts, utime=1, frame="lidar")
        nan = ll.lidar_message(np.array([[1, 2, np.nan]]), utime=1)
        with self.assertRaisesRegex(ll.MessageError, "point 0 is not finite"):
            ll.lidar_points(nan)


if __name__ == "__main__":
    unittest.main()
