# SPDX-License-Identifier: MIT
"""Encoders and decoders of the lidarflow LCM types (lcm_types/*.lcm), byte-compatible with
lcm-gen's C/C++ code.

Each type is described once as its field list, in the order and with the types and array
dimensions of its .lcm file; the wire codec and the 8-byte fingerprint both derive from that
list (the fingerprint by lcm-gen's own hash over member names, types and dimensions), so the
two cannot drift apart. The tests compare both with what lcm-gen generates from the .lcm files.

Decoding never trusts the message: every read is checked against the bytes that are there,
array lengths must be >= 0 and add up to exactly the message size, and the type's own
consistency rules (those of the bridge, bridge/wire.cpp) must hold. Anything else raises
MessageError naming the problem.
"""
import math
import struct

import numpy as np

__all__ = ["MessageError", "stereo_t", "lidar_t", "calibration_t", "scene_flow_t", "status_t", "ego_motion_t", "quality_t",
           "TYPES", "decode", "type_of"]


class MessageError(ValueError):
    """A message that cannot be encoded or decoded: what is wrong, in one line."""


# LCM primitive -> (struct code, big-endian numpy dtype). Arrays of `byte` stay bytes.
_PRIMITIVES = {
    "int8_t": ("b", ">i1"), "int16_t": ("h", ">i2"), "int32_t": ("i", ">i4"), "int64_t": ("q", ">i8"),
    "float": ("f", ">f4"), "double": ("d", ">f8"), "byte": ("B", "u1"), "boolean": ("b", ">i1"),
}
_NATIVE = {"int8_t": np.int8, "int16_t": np.int16, "int32_t": np.int32, "int64_t": np.int64,
           "float": np.float32, "double": np.float64, "boolean": np.int8}


def _lcm_hash(fields):
    """lcm-gen's struct hash (lcmgen.c: lcm_struct_hash), then the rotation every generated
    _get_hash_recursive applies for a type without nested types. int64 arithmetic as in C."""
    mask = (1 << 64) - 1

    def update(v, c):
        signed = v - (1 << 64) if v >> 63 else v
        return (((v << 8) & mask) ^ ((signed >> 55) & mask)) + c & mask

    def update_string(v, s):
        v = update(v, len(s))
        for ch in s.encode():
            v = update(v, ch if ch < 128 else ch - 256)  # C's char is signed
        return v

    v = 0x12345678
    for name, typ, dim in fields:
        v = update_string(v, name)
        v = update_string(v, typ)  # every member of these types is a primitive
        if dim is None:
            v = update(v, 0)
        else:
            v = update(v, 1)
            v = update(v, 1 if isinstance(dim, str) else 0)  # LCM_VAR = 1, LCM_CONST = 0
            v = update_string(v, str(dim))
    return ((v << 1) & mask) + (v >> 63)


class _Float32NaN(float):
    """A NaN decoded from a scalar float (float32) field, with its 4 bytes: Python floats are
    doubles, and converting a float32 signalling NaN to one and back quiets it (sets the quiet
    bit), which would change the bytes of a decode/encode round trip. encode() writes `raw`."""
    __slots__ = ("raw",)

    def __new__(cls, raw):
        self = super().__new__(cls, struct.unpack(">f", raw)[0])
        self.raw = raw
        return self

    def __repr__(self):
        return "nan(0x%s)" % self.raw.hex()


class _Reader:
    """Bounds-checked cursor over a message: a read past the end is a MessageError, never a
    short result."""

    def __init__(self, data, type_name):
        self.data, self.pos, self.type_name = data, 0, type_name

    def take(self, n, what):
        if n > len(self.data) - self.pos:
            raise MessageError("truncated %s: %s needs %d bytes at offset %d, the message has %d"
                               % (self.type_name, what, n, self.pos, len(self.data)))
        chunk = self.data[self.pos:self.pos + n]
        self.pos += n
        return chunk


class _Message:
    """Base of the message classes: construct with keyword arguments (others default to 0 / empty),
    encode() to bytes, Type.decode(bytes) back."""
    __slots__ = ()
    _FIELDS = ()  # (name, lcm type, None | constant length | name of the length field)
    TYPE_NAME = ""

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        cls.FINGERPRINT = _lcm_hash(cls._FIELDS)
        cls._PACKED_FINGERPRINT = struct.pack(">Q", cls.FINGERPRINT)
        cls._LENGTH_FIELDS = {dim for _, _, dim in cls._FIELDS if isinstance(dim, str)}

    def __init__(self, **values):
        for name, typ, dim in self._FIELDS:
            setattr(self, name, self._default(typ, dim))
        for name, value in values.items():
            if name not in self.__slots__:
                raise TypeError("%s has no field %r" % (self.TYPE_NAME, name))
            setattr(self, name, value)

    @staticmethod
    def _default(typ, dim):
        if typ == "string":
            return ""
        if dim is None:
            return 0.0 if typ in ("float", "double") else 0
        if typ == "byte":
            return b""
        return np.zeros(dim if isinstance(dim, int) else 0, _NATIVE[typ])

    def __repr__(self):
        parts = []
        for name, typ, dim in self._FIELDS:
            value = getattr(self, name)
            parts.append("%s=<%d %s>" % (name, len(value), typ) if dim is not None else "%s=%r" % (name, value))
        return "%s(%s)" % (self.TYPE_NAME, ", ".join(parts))

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        for name, typ, dim in self._FIELDS:
            a, b = getattr(self, name), getattr(other, name)
            if dim is not None and typ != "byte":
                if not np.array_equal(np.asarray(a), np.asarray(b)):
                    return False
            elif a != b and not (isinstance(a, float) and math.isnan(a) and math.isnan(b)):
                return False
        return True

    # lcm-python's API, so these classes also work with lcm.LCM().subscribe handlers.
    @classmethod
    def _get_packed_fingerprint(cls):
        return cls._PACKED_FINGERPRINT

    def check(self):
        """Raises MessageError when the fields are inconsistent (the type's rules beyond the wire)."""

    def encode(self, check=True):
        """The message's bytes (fingerprint first), as lcm-gen's encoders write them. Array
        lengths must equal their length fields. check=False skips check(), for writing
        deliberately inconsistent messages (tests of receivers)."""
        if check:
            self.check()
        out = [self._PACKED_FINGERPRINT]
        for name, typ, dim in self._FIELDS:
            value = getattr(self, name)
            try:
                if typ == "string":
                    raw = value.encode("utf-8", "surrogateescape")
                    if b"\0" in raw:
                        raise MessageError("%s.%s holds a NUL byte" % (self.TYPE_NAME, name))
                    out.append(struct.pack(">i", len(raw) + 1) + raw + b"\0")
                elif dim is None:
                    if type(value) is _Float32NaN and typ == "float":
                        out.append(value.raw)  # its exact bits (a signalling NaN stays one)
                    else:
                        out.append(struct.pack(">" + _PRIMITIVES[typ][0], value))
                else:
                    n = dim if isinstance(dim, int) else getattr(self, dim)
                    if typ == "byte":
                        raw = bytes(value)
                    else:
                        arr = np.asarray(value)
                        if arr.ndim != 1:
                            raise MessageError("%s.%s must be one-dimensional, got shape %s"
                                               % (self.TYPE_NAME, name, arr.shape))
                        raw = arr.astype(_PRIMITIVES[typ][1], casting="same_kind").tobytes()
                    count = len(raw) // np.dtype(_PRIMITIVES[typ][1]).itemsize
                    if count != n:
                        raise MessageError("%s.%s has %d entries, %s says %d"
                                           % (self.TYPE_NAME, name, count, dim if isinstance(dim, str) else "the type", n))
                    out.append(raw)
            except (struct.error, OverflowError, TypeError) as e:
                raise MessageError("%s.%s = %r cannot be encoded as %s: %s"
                                   % (self.TYPE_NAME, name, _short(value), typ, e)) from None
        return b"".join(out)

    @classmethod
    def decode(cls, data, check=True):
        """The message in `data` (bytes-like, the whole message). MessageError for a wrong
        fingerprint, truncated data, negative or inconsistent lengths, bytes left over, or
        (check=True) fields that break the type's rules."""
        data = bytes(data)
        if len(data) < 8:
            raise MessageError("truncated %s: %d bytes, not even the 8-byte fingerprint" % (cls.TYPE_NAME, len(data)))
        if data[:8] != cls._PACKED_FINGERPRINT:
            other = _BY_FINGERPRINT.get(data[:8])
            raise MessageError("bad fingerprint 0x%s for %s (expected 0x%016x)%s"
                               % (data[:8].hex(), cls.TYPE_NAME, cls.FINGERPRINT,
                                  ": this is a %s" % other.TYPE_NAME if other else ""))
        r = _Reader(data, cls.TYPE_NAME)
        r.pos = 8
        msg = cls.__new__(cls)
        for name, typ, dim in cls._FIELDS:
            if typ == "string":
                (n,) = struct.unpack(">i", r.take(4, name + " length"))
                if n < 1:
                    raise MessageError("%s.%s: string length %d (an LCM string holds at least its NUL)"
                                       % (cls.TYPE_NAME, name, n))
                raw = r.take(n, name)
                if raw[-1] != 0:
                    raise MessageError("%s.%s is not NUL-terminated" % (cls.TYPE_NAME, name))
                if 0 in raw[:-1]:  # C readers would see only the text before it
                    raise MessageError("%s.%s holds a NUL byte before its end" % (cls.TYPE_NAME, name))
                # surrogateescape: bytes that are not UTF-8 survive a decode/encode round trip.
                setattr(msg, name, raw[:-1].decode("utf-8", "surrogateescape"))
                continue
            code, be = _PRIMITIVES[typ]
            if dim is None:
                raw = r.take(struct.calcsize(code), name)
                (value,) = struct.unpack(">" + code, raw)
                if typ == "float" and value != value:
                    value = _Float32NaN(raw)
                if name in cls._LENGTH_FIELDS and value < 0:
                    raise MessageError("%s: negative length %s = %d" % (cls.TYPE_NAME, name, value))
                setattr(msg, name, value)
                continue
            n = dim if isinstance(dim, int) else getattr(msg, dim)
            raw = r.take(n * np.dtype(be).itemsize, "%s[%d]" % (name, n))
            setattr(msg, name, raw if typ == "byte" else np.frombuffer(raw, be).astype(_NATIVE[typ]))
        if r.pos != len(data):
            raise MessageError("wrong size: %d bytes, the %s declares %d (%d bytes left over)"
                               % (len(data), cls.TYPE_NAME, r.pos, len(data) - r.pos))
        if check:
            msg.check()
        return msg


def _short(value):
    text = repr(value)
    return text if len(text) < 60 else text[:57] + "..."


def _fail(type_name, fmt, *args):
    raise MessageError("inconsistent %s: %s" % (type_name, fmt % args))


def _side_ok(n):
    return 1 <= n <= 16384  # the bridge's bound on image sides (bridge/wire.cpp)


class stereo_t(_Message):
    """One rectified stereo pair (lcm_types/stereo_t.lcm)."""
    TYPE_NAME = "lidarflow.stereo_t"
    _FIELDS = (("utime", "int64_t", None), ("sequence", "int32_t", None), ("frame_number", "int64_t", None),
               ("width", "int32_t", None), ("height", "int32_t", None), ("row_stride", "int32_t", None),
               ("pixel_format", "int8_t", None), ("size", "int32_t", None),
               ("left", "byte", "size"), ("right", "byte", "size"))
    __slots__ = tuple(f[0] for f in _FIELDS)
    PIXEL_GRAY8, PIXEL_RGB8, PIXEL_BGR8 = 1, 2, 3
    BYTES_PER_PIXEL = {PIXEL_GRAY8: 1, PIXEL_RGB8: 3, PIXEL_BGR8: 3}

    def check(self):
        bpp = self.BYTES_PER_PIXEL.get(self.pixel_format)
        if bpp is None:
            _fail(self.TYPE_NAME, "unknown pixel_format %d (1 gray8, 2 rgb8, 3 bgr8)", self.pixel_format)
        if not (_side_ok(self.width) and _side_ok(self.height)):
            _fail(self.TYPE_NAME, "%dx%d (each side 1..16384)", self.width, self.height)
        if self.row_stride < self.width * bpp:
            _fail(self.TYPE_NAME, "row_stride %d < width %d x %d bytes", self.row_stride, self.width, bpp)
        if self.size != self.row_stride * self.height:
            _fail(self.TYPE_NAME, "size %d != row_stride %d x height %d", self.size, self.row_stride, self.height)


class lidar_t(_Message):
    """One LiDAR sweep as a point list (lcm_types/lidar_t.lcm)."""
    TYPE_NAME = "lidarflow.lidar_t"
    _FIELDS = (("utime", "int64_t", None), ("frame", "int8_t", None), ("lidar_to_camera", "double", 16),
               ("num_points", "int32_t", None),
               ("x", "float", "num_points"), ("y", "float", "num_points"), ("z", "float", "num_points"))
    __slots__ = tuple(f[0] for f in _FIELDS)
    FRAME_CAMERA, FRAME_LIDAR, FRAME_DISPARITY = 1, 2, 3

    def check(self):
        # bridge/wire.cpp decode_lidar, in its order.
        t = self.TYPE_NAME
        if self.frame not in (self.FRAME_CAMERA, self.FRAME_LIDAR, self.FRAME_DISPARITY):
            _fail(t, "unknown frame %d (1 camera, 2 lidar, 3 disparity)", self.frame)
        T = None
        if self.frame == self.FRAME_LIDAR:
            T = np.asarray(self.lidar_to_camera, np.float64).ravel()
            if T.size == 16:  # else encode() names the length mismatch
                bad = np.flatnonzero(~np.isfinite(T))
                if bad.size:
                    _fail(t, "lidar_to_camera[%d] is not finite", bad[0])
                if not np.array_equal(T[12:], [0, 0, 0, 1]):
                    _fail(t, "lidar_to_camera's last row is %g %g %g %g, not 0 0 0 1", *T[12:])
            else:
                T = None
        xyz = [np.asarray(getattr(self, k)) for k in ("x", "y", "z")]
        n = min(a.size for a in xyz) if all(a.ndim == 1 for a in xyz) else 0
        if n == 0:
            return
        with np.errstate(invalid="ignore"):  # a signalling NaN warns in the cast; it is refused below
            p = np.stack([a[:n].astype(np.float64) for a in xyz], axis=1)
        bad = np.flatnonzero(~np.all(np.isfinite(p), axis=1))
        if bad.size:
            _fail(t, "point %d is not finite", bad[0])
        if T is not None:
            T = T.reshape(4, 4)
            with np.errstate(over="ignore", invalid="ignore"):
                # In the bridge's order: T[r,0]*x + T[r,1]*y + T[r,2]*z + T[r,3], in double.
                cam = np.stack([T[r, 0] * p[:, 0] + T[r, 1] * p[:, 1] + T[r, 2] * p[:, 2] + T[r, 3]
                                for r in range(3)], axis=1)
            bad = np.flatnonzero(~np.all(np.abs(cam) <= float(np.finfo(np.float32).max), axis=1))
            if bad.size:
                _fail(t, "point %d is out of float range after lidar_to_camera", bad[0])


class calibration_t(_Message):
    """The rectified stereo camera (lcm_types/calibration_t.lcm)."""
    TYPE_NAME = "lidarflow.calibration_t"
    _FIELDS = (("utime", "int64_t", None), ("width", "int32_t", None), ("height", "int32_t", None),
               ("fx", "double", None), ("fy", "double", None), ("cx", "double", None), ("cy", "double", None),
               ("baseline", "double", None))
    __slots__ = tuple(f[0] for f in _FIELDS)

    # The C ABI's camera ranges (src/core/limits.hpp), which the bridge applies by creating an
    # estimator with the calibration before taking it.
    FOCAL_RANGE, PRINCIPAL_POINT_MAX, BASELINE_RANGE = (1.0, 1e6), 1e6, (1e-4, 1e4)

    def check(self):
        # bridge/wire.cpp decode_calibration, then the C ABI's ranges, as the bridge checks them.
        t = self.TYPE_NAME
        values = [("fx", self.fx), ("fy", self.fy), ("cx", self.cx), ("cy", self.cy), ("baseline", self.baseline)]
        for name, v in values:
            if not math.isfinite(v):
                _fail(t, "%s = %r is not finite", name, v)
        if not (self.fx > 0 and self.fy > 0 and self.baseline > 0):
            _fail(t, "fx, fy, baseline must be > 0 (got %g, %g, %g)", self.fx, self.fy, self.baseline)
        if not (0 <= self.width <= 16384 and 0 <= self.height <= 16384):
            _fail(t, "image size %dx%d (each side 0..16384, 0 = any)", self.width, self.height)
        (flo, fhi), pmax, (blo, bhi) = self.FOCAL_RANGE, self.PRINCIPAL_POINT_MAX, self.BASELINE_RANGE
        for name, v, lo, hi, unit in (("fx", self.fx, flo, fhi, "px"), ("fy", self.fy, flo, fhi, "px"),
                                      ("cx", self.cx, -pmax, pmax, "px"), ("cy", self.cy, -pmax, pmax, "px"),
                                      ("baseline", self.baseline, blo, bhi, "m")):
            if not lo <= v <= hi:
                _fail(t, "%s = %g %s is outside [%g, %g]", name, v, unit, lo, hi)


class scene_flow_t(_Message):
    """Dense scene flow of one frame pair (lcm_types/scene_flow_t.lcm); see arrays.flow_arrays."""
    TYPE_NAME = "lidarflow.scene_flow_t"
    _FIELDS = (("utime", "int64_t", None), ("utime0", "int64_t", None), ("sequence", "int32_t", None),
               ("lidar_flags", "int8_t", None), ("lidar_utime0", "int64_t", None), ("lidar_utime1", "int64_t", None),
               ("last_stage", "int8_t", None), ("image_width", "int32_t", None), ("image_height", "int32_t", None),
               ("step", "int8_t", None), ("width", "int32_t", None), ("height", "int32_t", None),
               ("encoding", "int8_t", None), ("scale", "float", None), ("compute_seconds", "float", None),
               ("plane_size", "int32_t", None), ("valid_size", "int32_t", None),
               ("u", "byte", "plane_size"), ("v", "byte", "plane_size"), ("d0", "byte", "plane_size"),
               ("d1", "byte", "plane_size"), ("valid", "byte", "valid_size"))
    __slots__ = tuple(f[0] for f in _FIELDS)
    ENCODING_FLOAT32, ENCODING_INT16 = 1, 2
    LIDAR_T0, LIDAR_T1 = 1, 2
    VALUE_BYTES = {ENCODING_FLOAT32: 4, ENCODING_INT16: 2}

    def check(self):
        t = self.TYPE_NAME
        value_bytes = self.VALUE_BYTES.get(self.encoding)
        if value_bytes is None:
            _fail(t, "unknown encoding %d (1 float32, 2 int16)", self.encoding)
        if not (_side_ok(self.image_width) and _side_ok(self.image_height) and 1 <= self.step <= 16):
            _fail(t, "image %dx%d (each side 1..16384), step %d (1..16)", self.image_width, self.image_height, self.step)
        if (self.width != -(-self.image_width // self.step)) or (self.height != -(-self.image_height // self.step)):
            _fail(t, "planes %dx%d, image %dx%d subsampled by %d", self.width, self.height, self.image_width,
                  self.image_height, self.step)
        n = self.width * self.height
        if self.plane_size != n * value_bytes or self.valid_size != n:
            _fail(t, "%dx%d planes with plane_size %d, valid_size %d", self.width, self.height, self.plane_size,
                  self.valid_size)
        if self.encoding == self.ENCODING_INT16 and not (math.isfinite(self.scale) and self.scale > 0):
            _fail(t, "int16 encoding with scale %g (finite, > 0)", self.scale)
        if len(self.valid) == n:  # else encode() names the length mismatch
            bad = np.flatnonzero(np.frombuffer(bytes(self.valid), np.uint8) > 1)
            if bad.size:
                _fail(t, "valid[%d] = %d, not 0 or 1", bad[0], bytes(self.valid)[bad[0]])


class status_t(_Message):
    """Heartbeat of lidarflow-lcm-bridge (lcm_types/status_t.lcm)."""
    TYPE_NAME = "lidarflow.status_t"
    _FIELDS = tuple([("utime", "int64_t", None), ("uptime_seconds", "double", None)]
                    + [(name, "int64_t", None) for name in (
                        "stereo_received", "stereo_lost_in_transport", "stereo_processed", "results_published",
                        "frames_with_lidar", "dropped_stale", "dropped_out_of_order", "dropped_no_calibration",
                        "dropped_calibration_mismatch", "dropped_malformed", "dropped_estimator_error",
                        "dropped_shutdown", "dropped_unpaired", "skipped_other_shard", "lidar_received", "lidar_malformed",
                        "lidar_rejected", "calibration_received", "calibration_malformed")]
                    + [("queue_depth", "int32_t", None), ("queue_capacity", "int32_t", None), ("busy", "int8_t", None),
                       ("shard_index", "int32_t", None), ("shard_count", "int32_t", None),
                       ("shards_dead", "int32_t", None), ("pairs_lost_dead_shard", "int64_t", None)]
                    + [(name, "int64_t", None) for name in (
                        "instance_id", "shard_index_conflicts", "shard_results_ignored", "shard_messages_refused",
                        "pairs_lost_calibration_change")]
                    + [(name, "float", None) for name in (
                        "latency_last_ms", "latency_mean_ms", "latency_max_ms", "compute_last_ms", "compute_mean_ms")]
                    + [("last_error", "string", None)])
    __slots__ = tuple(f[0] for f in _FIELDS)


class ego_motion_t(_Message):
    """The static scene's rigid motion between the frames of the scene_flow_t with the same utime,
    utime0 and sequence (lcm_types/ego_motion_t.lcm): transform T (16 doubles, row-major) maps a
    static point's coordinates in the left camera frame at utime0 to those at utime,
    X1 = T [X0; 1] [m]; the camera's own motion is inv(T). matrix() gives T as (4, 4)."""
    TYPE_NAME = "lidarflow.ego_motion_t"
    _FIELDS = (("utime", "int64_t", None), ("utime0", "int64_t", None), ("sequence", "int32_t", None),
               ("state", "int8_t", None), ("transform", "double", 16), ("inliers", "int32_t", None),
               ("candidates", "int32_t", None))
    __slots__ = tuple(f[0] for f in _FIELDS)
    STATE_OK, STATE_NOT_RUN, STATE_NO_CALIBRATION, STATE_TOO_FEW_INLIERS, STATE_DISABLED = 0, 1, 2, 3, 4

    def __init__(self, **values):
        values.setdefault("transform", np.eye(4).ravel())
        super().__init__(**values)

    def matrix(self):
        """T as a new (4, 4) float64 array."""
        return np.array(self.transform, np.float64).reshape(4, 4)

    def check(self):
        # bridge/wire.cpp decode_ego_motion, in its order.
        t = self.TYPE_NAME
        if not self.STATE_OK <= self.state <= self.STATE_DISABLED:
            _fail(t, "unknown state %d (0 ok .. 4 disabled)", self.state)
        T = np.asarray(self.transform, np.float64).ravel()
        if T.size != 16:
            return  # encode() names the length mismatch
        bad = np.flatnonzero(~np.isfinite(T))
        if bad.size:
            _fail(t, "transform[%d] is not finite", bad[0])
        if not np.array_equal(T[12:], [0, 0, 0, 1]):
            _fail(t, "transform's last row is %g %g %g %g, not 0 0 0 1", *T[12:])
        if self.state == self.STATE_OK:
            R = T.reshape(4, 4)[:3, :3]
            with np.errstate(over="ignore", invalid="ignore"):  # huge entries: not a rotation either way
                RtR = R.T @ R
                ok = np.abs(RtR - np.eye(3)) <= 1e-6
            if not ok.all():
                i, j = np.unravel_index(np.argmax(~ok), ok.shape)
                _fail(t, "transform's rotation is not orthonormal ((R^T R)[%d][%d] = %.9g)", i, j, RtR[i, j])
            det = np.linalg.det(R)
            if not det > 0:
                _fail(t, "transform's rotation has determinant %g (a reflection)", det)
        elif not np.array_equal(T, np.eye(4).ravel()):
            _fail(t, "state %d (no ego-motion) with a transform other than the identity", self.state)
        if self.inliers < 0 or self.candidates < 0 or self.inliers > self.candidates:
            _fail(t, "inliers %d, candidates %d (0 <= inliers <= candidates)", self.inliers, self.candidates)


class quality_t(_Message):
    """The input quality of the scene_flow_t with the same utime, utime0 and sequence
    (lcm_types/quality_t.lcm): flags (FLAG_* bits, 0 = ok) and reason (one clause per flag, ""
    when ok). states() names the set flags; docs/CONVENTIONS.md says what each means."""
    TYPE_NAME = "lidarflow.quality_t"
    _FIELDS = (("utime", "int64_t", None), ("utime0", "int64_t", None), ("sequence", "int32_t", None),
               ("flags", "int32_t", None), ("reason", "string", None))
    __slots__ = tuple(f[0] for f in _FIELDS)
    FLAG_LEFT_RIGHT_SWAPPED, FLAG_NOT_RECTIFIED, FLAG_CALIBRATION_SIZE_MISMATCH = 1, 2, 4
    FLAG_BLANK_FRAME, FLAG_LIDAR_DISAGREES = 8, 16
    NAMES = {1: "left_right_swapped", 2: "not_rectified", 4: "calibration_size_mismatch", 8: "blank_frame",
             16: "lidar_disagrees"}

    def states(self):
        """The names of the set flags, in bit order (an unknown bit as "unknown")."""
        return tuple(self.NAMES.get(1 << b, "unknown") for b in range(32) if self.flags >> b & 1)

    def check(self):
        if self.flags < 0 or self.flags & ~sum(self.NAMES):
            _fail(self.TYPE_NAME, "unknown flags 0x%x (known: 0x%x)", self.flags & 0xffffffff, sum(self.NAMES))
        if (self.flags == 0) != (self.reason == ""):
            _fail(self.TYPE_NAME, "flags 0x%x with reason %r (a reason exactly when a flag is set)", self.flags,
                  _short(self.reason))


TYPES = (stereo_t, lidar_t, calibration_t, scene_flow_t, status_t, ego_motion_t, quality_t)
_BY_FINGERPRINT = {t._PACKED_FINGERPRINT: t for t in TYPES}


def type_of(data):
    """The message class whose fingerprint `data` starts with, or None (another type)."""
    return _BY_FINGERPRINT.get(bytes(data[:8]))


def decode(data, check=True):
    """Decodes a message of any of the seven types, chosen by its fingerprint; MessageError for
    an unknown fingerprint or a malformed message."""
    cls = type_of(data)
    if cls is None:
        raise MessageError("unknown fingerprint 0x%s: not a lidarflow message type" % bytes(data[:8]).hex())
    return cls.decode(data, check=check)
