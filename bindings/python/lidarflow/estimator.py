# SPDX-License-Identifier: MIT
"""The Estimator class: one lidarflow handle (see include/lidarflow/lidarflow.h)."""
import collections
import ctypes
import threading
import weakref

import numpy as np

from . import _lib, _log
from ._lib import lib


class LidarflowError(RuntimeError):
    """A failed call of the C library: .status is the lf_status_t code, .message its text."""

    def __init__(self, status, message):
        self.status = status
        self.message = message
        super().__init__("%s (%s)" % (message, lib.lf_status_string(status).decode()))


class _Busy:
    """Holds an Estimator's lock for one call. Inside a handler of the library's messages, a call
    on an Estimator that another thread is using is refused (ERR_BAD_STATE) rather than waited
    for: the handler may run on a frame worker whose frame that thread's call waits for, and
    would then wait forever (the library refuses such calls too)."""

    __slots__ = ("_lock",)

    def __init__(self, lock):
        self._lock = lock

    def __enter__(self):
        if not self._lock.acquire(blocking=not _log.in_callback()):
            raise LidarflowError(_lib.ERR_BAD_STATE, "an Estimator call from a log handler while another "
                                 "call on it runs (e.g. one waiting for the frame being logged)")
        return self

    def __exit__(self, *exc):
        self._lock.release()
        return False


_LIDAR_KINDS = {"disparity": _lib.LIDAR_DISPARITY, "camera": _lib.LIDAR_POINTS_CAMERA,
                "lidar": _lib.LIDAR_POINTS_LIDAR}
_COLOUR_FORMATS = {"rgb": _lib.PIXEL_RGB8, "bgr": _lib.PIXEL_BGR8}
MAX_IMAGE_SIDE = 16384  # lf_push_frame refuses larger sides (lidarflow.h)
_INT64_MIN, _INT64_MAX = -(1 << 63), (1 << 63) - 1
_RESULT_PLANES = (("u", np.float32), ("v", np.float32), ("d0", np.float32), ("d1", np.float32),
                  ("valid", np.uint8), ("confidence", np.float32))


def _int64(what, value):
    """value as an int that fits the C ABI's int64_t; ValueError otherwise (ctypes would wrap it
    silently: 2**64 + 5 would reach the library as 5)."""
    v = int(value)
    if not _INT64_MIN <= v <= _INT64_MAX:
        raise ValueError("%s = %d is outside int64 [-2**63, 2**63 - 1]" % (what, v))
    return v


def _image_view(name, a, colour_order):
    """lf_image_t over a numpy image without copying; ValueError when it cannot be one."""
    if not isinstance(a, np.ndarray):
        raise ValueError("%s must be a numpy array, got %s" % (name, type(a).__name__))
    if a.dtype != np.uint8:
        raise ValueError("%s must have dtype uint8, got %s" % (name, a.dtype))
    if a.ndim == 2:
        channels, fmt = 1, _lib.PIXEL_GRAY8
    elif a.ndim == 3 and a.shape[2] == 3:
        if colour_order is None:
            raise ValueError("%s is a colour image (shape %s): pass its channel order, "
                             "colour_order=\"bgr\" for cv2.imread images or colour_order=\"rgb\" "
                             "for PIL/imageio ones (or convert it to gray)" % (name, a.shape))
        channels, fmt = 3, _COLOUR_FORMATS[colour_order]
    else:
        raise ValueError("%s must have shape (H, W) or (H, W, 3), got %s" % (name, a.shape))
    if a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError("%s is empty (shape %s)" % (name, a.shape))
    # Checked here: lf_image_t's uint32 sides would wrap a width of 2**32 + 64 to 64.
    if a.shape[0] > MAX_IMAGE_SIDE or a.shape[1] > MAX_IMAGE_SIDE:
        raise ValueError("%s is %d x %d px (width x height): each side must be at most %d"
                         % (name, a.shape[1], a.shape[0], MAX_IMAGE_SIDE))
    # Rows may be padded (any positive row stride); the pixels of a row must be packed.
    packed = a.strides[1] == channels and (a.ndim == 2 or a.strides[2] == 1)
    if not packed or a.strides[0] < a.shape[1] * channels:
        raise ValueError("%s must have packed rows (strides (S, %d%s) with S >= %d), got strides %s; "
                         "use np.ascontiguousarray" % (name, channels, ", 1" if channels == 3 else "",
                                                       a.shape[1] * channels, a.strides))
    return _lib.Image(a.ctypes.data, a.shape[1], a.shape[0], a.strides[0], fmt)


def _colour_order(colour_order, color_order):
    """The one channel order given (None: none given; gray images need none)."""
    if colour_order is not None and color_order is not None and colour_order != color_order:
        raise ValueError("colour_order=%r and color_order=%r disagree; pass one" % (colour_order, color_order))
    order = colour_order if colour_order is not None else color_order
    if order is not None and order not in _COLOUR_FORMATS:
        raise ValueError("colour_order must be 'rgb' or 'bgr', got %r" % (order,))
    return order


def _lidar_view(lidar, kind):
    if kind not in _LIDAR_KINDS:
        raise ValueError("lidar_kind must be one of %s, got %r" % (sorted(_LIDAR_KINDS), kind))
    if not isinstance(lidar, np.ndarray):
        raise ValueError("lidar must be a numpy array, got %s" % type(lidar).__name__)
    if lidar.dtype != np.float32:
        raise ValueError("lidar must have dtype float32, got %s" % lidar.dtype)
    if lidar.ndim != 2 or lidar.shape[1] < 3:
        raise ValueError("lidar must have shape (N, 3) or (N, K >= 3), got %s" % (lidar.shape,))
    if lidar.shape[0] > 0 and (lidar.strides[1] != 4 or lidar.strides[0] < 12):
        raise ValueError("lidar entries must hold 3 packed float32 (strides (S >= 12, 4)), got strides %s"
                         % (lidar.strides,))
    if lidar.shape[0] > 0xFFFFFFFF:
        raise ValueError("lidar has %d entries, at most 2**32 - 1" % lidar.shape[0])
    stride = lidar.strides[0] if lidar.shape[0] > 0 else 12
    return _lib.Lidar(_LIDAR_KINDS[kind], lidar.shape[0], lidar.ctypes.data if lidar.shape[0] else None, stride)


def _plane(name, a, shape, dtype, channels=1):
    """Plane over a caller array that the library writes into; ValueError when it cannot."""
    want = shape if channels == 1 else shape + (channels,)
    if not isinstance(a, np.ndarray) or a.dtype != dtype or a.shape != want:
        raise ValueError("out[%r] must be a %s array of shape %s, got %s" % (
            name, np.dtype(dtype).name, want,
            "%s %s" % (a.dtype, a.shape) if isinstance(a, np.ndarray) else type(a).__name__))
    if not a.flags.writeable:
        raise ValueError("out[%r] is read-only" % name)
    item = np.dtype(dtype).itemsize
    packed = a.strides[1] == item * channels and (channels == 1 or a.strides[2] == item)
    if not packed or a.strides[0] < shape[1] * item * channels:
        raise ValueError("out[%r] must have packed rows, got strides %s" % (name, a.strides))
    return _lib.Plane(a.ctypes.data, a.strides[0])


class Estimator:
    """Dense scene flow from a stream of rectified stereo frames plus optional sparse LiDAR.

    Estimator(fx, fy, cx, cy, baseline, lidar_to_camera=None, options=None, image_size=None, raw=None)
      fx, fy, cx, cy [px] and baseline [m] describe the rectified stereo camera;
      lidar_to_camera is an optional 4x4 transform LiDAR frame -> left camera frame (needed for
      lidar_kind="lidar"); image_size (width, height) is the images' size the calibration is for
      (another size is warned about once, or refused with the option "input.strict"); raw
      ({"left": {K, D, R, P}, "right": ...}, as read_calibration gives it) makes the Estimator
      rectify each pushed pair, results then being in the rectified left camera; options maps option keys (see lidarflow.h) to values, set in order
      ("threads" defaults to every CPU this process may use, fewer while other processes keep
      them busy; results do not depend on it).

    Each push() after the first computes the scene flow between the previous frame and the new
    one. Use as a context manager or call close(); a forgotten handle is freed by the garbage
    collector. Calls on one Estimator from several threads are serialised; distinct Estimators
    run in parallel (ctypes releases the GIL while the library computes).
    """

    def __init__(self, fx, fy, cx, cy, baseline, lidar_to_camera=None, options=None, image_size=None, raw=None):
        cal = _lib.Calibration()
        cal.struct_size = ctypes.sizeof(_lib.Calibration)
        cal.fx, cal.fy, cal.cx, cal.cy, cal.baseline = float(fx), float(fy), float(cx), float(cy), float(baseline)
        if image_size is not None:
            cal.image_width, cal.image_height = (int(v) for v in image_size)
        if raw is not None:
            cal.rectify = 1
            for side, c in (("left", cal.raw_left), ("right", cal.raw_right)):
                for name, n in (("K", 9), ("D", 8), ("R", 9), ("P", 12)):
                    v = np.asarray(raw[side][name], dtype=np.float64).ravel()
                    if v.size != n:
                        raise ValueError("raw[%r][%r] must have %d values, got %d" % (side, name, n, v.size))
                    getattr(c, name)[:] = [float(x) for x in v]
        if lidar_to_camera is not None:
            t = np.asarray(lidar_to_camera, dtype=np.float64)
            if t.shape != (4, 4):
                raise ValueError("lidar_to_camera must be 4x4, got shape %s" % (t.shape,))
            cal.has_lidar_to_camera = 1
            cal.lidar_to_camera[:] = [float(v) for v in t.ravel()]
        opt = ctypes.c_void_p()
        _check(lib.lf_options_create(ctypes.byref(opt)), None)
        try:
            for key, value in (options or {}).items():
                _set_option(opt, key, value)
            handle = ctypes.c_void_p()
            _check(lib.lf_create(opt, ctypes.byref(cal), ctypes.byref(handle)), None)
        finally:
            lib.lf_options_destroy(opt)
        self._handle = handle
        self._last_timestamp = None
        self._busy = threading.RLock()
        # Frees the handle exactly once: at close(), or when the object is collected.
        self._finalizer = weakref.finalize(self, lib.lf_destroy, handle)

    # --- lifetime ---
    def close(self):
        """Frees the library handle. Idempotent; the Estimator is unusable afterwards."""
        with self._locked():
            self._finalizer()
            self._handle = None

    @property
    def closed(self):
        return self._handle is None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def _h(self):
        if self._handle is None:
            raise ValueError("the Estimator is closed")
        return self._handle

    def _locked(self):
        return _Busy(self._busy)

    # --- frames ---
    def push(self, left, right, lidar=None, timestamp=None, lidar_kind="disparity", colour_order=None,
             color_order=None):
        """Adds a stereo frame; returns True when a result (previous frame -> this one) is ready;
        with the option frames_in_flight N, when this push handed over a pair with a result: the
        oldest in flight once N are, i.e. the pair that ended N - 1 frames before (see flush).

        left, right: uint8 arrays (H, W) gray or (H, W, 3) colour, packed pixels, any row
        stride; both the same shape. They are copied. Colour arrays need colour_order (or its
        spelling color_order) "bgr" (cv2.imread) or "rgb" (PIL, imageio): there is no default,
        because the wrong order silently changes the flow.
        lidar: None, or a float32 (N, K >= 3) array whose first three columns are (x, y, d)
        pixel + disparity (lidar_kind="disparity"), (x, y, z) metres in the left camera frame
        ("camera") or in the LiDAR frame ("lidar"). timestamp: int microseconds, increasing;
        None = the previous frame's + 1. Raises ValueError for malformed arrays and
        LidarflowError when the library rejects the frame (the Estimator is then unchanged).
        """
        colour_order = _colour_order(colour_order, color_order)
        li = _image_view("left", left, colour_order)
        ri = _image_view("right", right, colour_order)
        if left.shape != right.shape:
            raise ValueError("left and right differ in shape: %s and %s" % (left.shape, right.shape))
        lv = None if lidar is None else _lidar_view(lidar, lidar_kind)
        if timestamp is not None:
            timestamp = _int64("timestamp", timestamp)
        with self._locked():
            h = self._h()
            # The default under the lock: two threads pushing with timestamp=None must not
            # both read the same previous timestamp.
            if timestamp is None:
                timestamp = 0 if self._last_timestamp is None else self._last_timestamp + 1
                if timestamp > _INT64_MAX:
                    raise ValueError("timestamp: the previous frame's is 2**63 - 1, there is no later one")
            _check(lib.lf_push_frame(h, timestamp, ctypes.byref(li), ctypes.byref(ri),
                                     ctypes.byref(lv) if lv is not None else None), h)
            self._last_timestamp = timestamp
            return bool(lib.lf_has_result(h))

    def flush(self):
        """With the option frames_in_flight > 1 (push hands results over late, in order): waits
        for the oldest pair in flight and hands it over. Returns None when no pair was in
        flight, else whether it has a result (a failed pair has none; reading it raises the
        pair's error). At the end of a stream: ``while est.flush() is not None: ...``."""
        with self._locked():
            h = self._h()
            status = lib.lf_flush(h)
            if status == _lib.ERR_NOT_READY:
                return None
            _check(status, h)
            return bool(lib.lf_has_result(h))

    def reset(self):
        """Forgets the previous frame and the result (a new sequence, any size, may follow)."""
        with self._locked():
            h = self._h()
            _check(lib.lf_reset(h), h)
            self._last_timestamp = None

    @property
    def has_result(self):
        with self._locked():
            return bool(lib.lf_has_result(self._h()))

    # --- results ---
    def info(self):
        """dict: width, height, last_stage, t0_us, t1_us, total_seconds, timings [(name, s)]."""
        with self._locked():
            h = self._h()
            i = _result_info(h)
            timings = []
            for k in range(i.timing_count):
                name, sec = ctypes.c_char_p(), ctypes.c_double()
                _check(lib.lf_get_timing(h, k, ctypes.byref(name), ctypes.byref(sec)), h)
                timings.append((name.value.decode(), sec.value))
        return {"width": i.width, "height": i.height, "last_stage": _lib.STAGE_NAMES.get(i.last_stage),
                "t0_us": i.t0_us, "t1_us": i.t1_us, "total_seconds": i.total_seconds,
                "rectified": bool(i.rectified), "timings": timings}

    def result(self, out=None):
        """The latest result as a dict of numpy arrays: u, v, d0, d1, confidence (H, W) float32,
        valid (H, W) uint8 and flow (H, W, 2) float32 (u, v per pixel, OpenCV's layout). u, v,
        d0, d1 and flow are NaN where valid is 0, confidence 0 (docs/CONVENTIONS.md). The
        library writes the planes straight into numpy memory; flow is a copy of u and v.

        out: None (new arrays), or a dict holding preallocated arrays for any subset of those
        keys (packed rows, any row stride, writeable); only those planes are written, in place,
        and out is returned. Raises LidarflowError (status ERR_NOT_READY) before two frames.
        """
        with self._locked():
            h = self._h()
            i = _result_info(h)
            shape = (i.height, i.width)
            planes = {name: (shape, dtype) for name, dtype in _RESULT_PLANES}
            planes["flow"] = (shape + (2,), np.float32)
            out = _out_dict(out, planes)
            if "flow" in out:
                _plane("flow", out["flow"], shape, np.float32, 2)
            # u and v in arrays of their own when flow is asked for without them.
            uv = {name: out[name] if name in out else np.empty(shape, np.float32) for name in ("u", "v")
                  if name in out or "flow" in out}
            b = _lib.ResultBuffers()
            b.struct_size = ctypes.sizeof(_lib.ResultBuffers)
            b.width, b.height = i.width, i.height
            for name, dtype in _RESULT_PLANES:
                if name in out or name in uv:
                    setattr(b, name, _plane(name, uv.get(name, out.get(name)), shape, dtype))
            _check(lib.lf_get_result(h, ctypes.byref(b)), h)
            if "flow" in out:
                out["flow"][..., 0] = uv["u"]
                out["flow"][..., 1] = uv["v"]
        return out

    def points3d(self, out=None):
        """The latest result in metres: dict with points and motion (H, W, 3) float32 (the point
        at t0 in the left camera frame at t0, and its position at t1 in the camera frame at t1
        minus that) and valid (H, W) uint8; NaN where not valid. out: as in result()."""
        with self._locked():
            h = self._h()
            i = _result_info(h)
            shape = (i.height, i.width)
            out = _out_dict(out, {"points": (shape + (3,), np.float32), "motion": (shape + (3,), np.float32),
                                  "valid": (shape, np.uint8)})
            b = _lib.Points3dBuffers()
            b.struct_size = ctypes.sizeof(_lib.Points3dBuffers)
            b.width, b.height = i.width, i.height
            for name in ("points", "motion"):
                if name in out:
                    setattr(b, name, _plane(name, out[name], shape, np.float32, 3))
            if "valid" in out:
                b.valid = _plane("valid", out["valid"], shape, np.uint8)
            _check(lib.lf_get_points3d(h, ctypes.byref(b)), h)
        return out

    def ego_motion(self):
        """(T, inliers): the static scene's rigid motion between the result's frames as a (4, 4)
        float64 array T with X1 = T @ [X0, 1] (a static point's coordinates in the left camera
        frame at t0 to those at t1, metres; the camera's own motion is inv(T)), and how many
        matches support it. Raises LidarflowError: ERR_NOT_READY before two frames,
        ERR_BAD_STATE when the result has none (the message says why, e.g. no stage 4)."""
        with self._locked():
            h = self._h()
            e = _lib.EgoMotion()
            e.struct_size = ctypes.sizeof(_lib.EgoMotion)
            _check(lib.lf_get_ego_motion(h, ctypes.byref(e)), h)
        if e.state != _lib.EGO_OK:
            raise LidarflowError(_lib.ERR_BAD_STATE, "no ego-motion: " +
                                 _lib.EGO_STATE_NAMES.get(e.state, "unknown state %d" % e.state))
        return np.array(e.transform[:], dtype=np.float64).reshape(4, 4), int(e.inliers)

    def quality(self):
        """The latest result's input quality: a Quality (flags, states, reason) whose states are
        the names of the set flags ("left_right_swapped", "not_rectified",
        "calibration_size_mismatch", "blank_frame", "lidar_disagrees"; empty when ok) and reason
        one English clause per state (docs/CONVENTIONS.md says what each means and what to do).
        Raises LidarflowError(ERR_NOT_READY) before two frames."""
        with self._locked():
            h = self._h()
            flags = ctypes.c_uint32()
            reason = ctypes.c_char_p()
            _check(lib.lf_get_quality(h, ctypes.byref(flags), ctypes.byref(reason)), h)
            text = (reason.value or b"").decode()
        states = tuple(lib.lf_quality_name(bit).decode() for bit in _lib.QUALITY_FLAGS if flags.value & bit)
        return Quality(flags.value, states, text)

    def object_motion(self, out=None):
        """The latest result's object motion: dict with motion (H, W, 3) float32, X1 - T X0 in
        metres in the left camera frame at t1 (scene flow without the camera's own motion, about
        0 on the static world; NaN where not valid) and valid (H, W) uint8. out: as in result().
        Raises like ego_motion()."""
        with self._locked():
            h = self._h()
            i = _result_info(h)
            shape = (i.height, i.width)
            out = _out_dict(out, {"motion": (shape + (3,), np.float32), "valid": (shape, np.uint8)})
            b = _lib.ObjectMotionBuffers()
            b.struct_size = ctypes.sizeof(_lib.ObjectMotionBuffers)
            b.width, b.height = i.width, i.height
            if "motion" in out:
                b.motion = _plane("motion", out["motion"], shape, np.float32, 3)
            if "valid" in out:
                b.valid = _plane("valid", out["valid"], shape, np.uint8)
            _check(lib.lf_get_object_motion(h, ctypes.byref(b)), h)
        return out


class Quality(collections.namedtuple("Quality", "flags states reason")):
    """Input quality of a result (Estimator.quality()): flags (lf_quality_flag_t bits, 0 = ok),
    states (names of the set flags) and reason ("" when ok)."""
    __slots__ = ()

    @property
    def ok(self):
        return self.flags == 0

    def __str__(self):
        return "ok" if self.ok else "%s (%s)" % (", ".join(self.states), self.reason)


def _result_info(h):
    i = _lib.ResultInfo()
    i.struct_size = ctypes.sizeof(_lib.ResultInfo)
    _check(lib.lf_get_result_info(h, ctypes.byref(i)), h)
    return i


def _out_dict(out, planes):
    """out, checked against the known planes {name: (shape, dtype)}; new arrays when None."""
    if out is None:
        return {name: np.empty(shape, dtype) for name, (shape, dtype) in planes.items()}
    if not isinstance(out, dict):
        raise ValueError("out must be a dict of numpy arrays, got %s" % type(out).__name__)
    unknown = set(out) - set(planes)
    if unknown:
        raise ValueError("out has unknown keys %s (known: %s)" % (sorted(unknown), sorted(planes)))
    return out


def _set_option(opt, key, value):
    k = key.encode()
    if isinstance(value, str):
        st = lib.lf_options_set_string(opt, k, value.encode())
    elif isinstance(value, (bool, int, np.integer)):
        st = lib.lf_options_set_int(opt, k, _int64("option %r" % key, value))
    elif isinstance(value, (float, np.floating)):
        st = lib.lf_options_set_float(opt, k, float(value))
    else:
        raise ValueError("option %r: unsupported value type %s" % (key, type(value).__name__))
    if st != _lib.OK:
        raise LidarflowError(st, lib.lf_options_last_error(opt).decode())


def _check(status, handle):
    if status != _lib.OK:
        raise LidarflowError(status, lib.lf_last_error(handle).decode())
