# SPDX-License-Identifier: MIT
"""numpy views of the lidarflow LCM messages, and messages built from numpy arrays.

    flow_arrays(scene_flow_t)           -> flow (H, W, 2), u, v, d0, d1 (float32, NaN where not
                                           valid), valid (bool)
    points3d(scene_flow_t, calibration) -> 3-D points at t0 and t1 and their motion [m]
    stereo_images / lidar_points        -> the inputs as arrays (what the bridge gives the estimator)
    stereo_message / lidar_message / calibration_message / scene_flow_message -> messages to publish
"""
import math
import numbers

import numpy as np

from .messages import MessageError, calibration_t, lidar_t, scene_flow_t, stereo_t

__all__ = ["flow_arrays", "pixel_grid", "points3d", "stereo_images", "lidar_points", "stereo_message",
           "lidar_message", "calibration_message", "scene_flow_message"]

_INT16_SCALE = np.float32(1.0 / 64.0)  # bridge/wire.hpp kInt16Scale
_COLOUR = {"rgb": stereo_t.PIXEL_RGB8, "bgr": stereo_t.PIXEL_BGR8}
_LIDAR_FRAMES = {"camera": lidar_t.FRAME_CAMERA, "lidar": lidar_t.FRAME_LIDAR, "disparity": lidar_t.FRAME_DISPARITY}


def _checked(msg, cls):
    if not isinstance(msg, cls):
        raise TypeError("expected a %s, got %s" % (cls.TYPE_NAME, type(msg).__name__))
    msg.check()  # a message built or edited by hand gets the decoder's checks too
    return msg


def flow_arrays(msg):
    """The planes of a scene_flow_t as (height, width) arrays: u, v, d0, d1 float32 in
    full-resolution pixels (ENCODING_INT16 values times `scale`), NaN where not valid, valid
    (bool), and flow (height, width, 2) float32, u and v per pixel as Estimator.result() gives
    them (docs/CONVENTIONS.md). With step > 1, plane pixel (i, j) is image pixel (i * step, j * step): see
    pixel_grid(). MessageError for inconsistent messages."""
    _checked(msg, scene_flow_t)
    shape = (msg.height, msg.width)
    valid = np.frombuffer(bytes(msg.valid), np.uint8).reshape(shape).astype(bool)
    out = {}
    for name in ("u", "v", "d0", "d1"):
        raw = bytes(getattr(msg, name))
        if msg.encoding == scene_flow_t.ENCODING_FLOAT32:
            plane = np.frombuffer(raw, "<f4").astype(np.float32)
        else:  # float32 product, as the bridge's own decoder computes it (inf past float's range)
            with np.errstate(over="ignore"):
                plane = np.frombuffer(raw, "<i2").astype(np.float32) * np.float32(msg.scale)
        plane = plane.reshape(shape)
        plane[~valid] = np.nan
        out[name] = plane
    out["valid"] = valid
    out["flow"] = np.stack((out["u"], out["v"]), axis=-1)
    return out


def pixel_grid(msg):
    """(x, y): int32 (height, width) arrays of the image column and row of each plane pixel."""
    _checked(msg, scene_flow_t)
    ys, xs = np.mgrid[0:msg.height, 0:msg.width].astype(np.int32) * np.int32(msg.step)
    return xs, ys


def _camera(calibration, kw):
    if calibration is None:
        cal = kw
    elif isinstance(calibration, calibration_t):
        cal = {k: getattr(calibration, k) for k in ("fx", "fy", "cx", "cy", "baseline", "width", "height")}
    else:
        cal = dict(calibration)
    missing = [k for k in ("fx", "fy", "cx", "cy", "baseline") if k not in cal]
    if missing:
        raise ValueError("calibration lacks %s" % ", ".join(missing))
    fx, fy, cx, cy, b = (float(cal[k]) for k in ("fx", "fy", "cx", "cy", "baseline"))
    if not all(math.isfinite(x) for x in (fx, fy, cx, cy, b)) or not (fx > 0 and fy > 0 and b > 0):
        raise ValueError("calibration needs finite values and fx, fy, baseline > 0 (got fx %g, fy %g, cx %g, cy %g, "
                         "baseline %g)" % (fx, fy, cx, cy, b))
    return fx, fy, cx, cy, b, int(cal.get("width", 0) or 0), int(cal.get("height", 0) or 0)


def points3d(msg, calibration=None, **camera):
    """Metric 3-D reading of a scene_flow_t, as lf_get_points3d computes it (lidarflow.h):
    Z = fx * baseline / d, X = (x - cx) Z / fx, Y = (y - cy) Z / fy, with (x, y, d0) at t0 and
    (x + u, y + v, d1) at t1, in double, each coordinate cast to float32 once.

    calibration: a calibration_t, a mapping with fx, fy, cx, cy, baseline (width and height
    optional), or None with those as keyword arguments. A calibration_t or mapping whose
    width/height are non-zero must match the message's image size.
    Returns a dict of (height, width, 3) float32 arrays points (t0, left camera frame at t0),
    points1 (t1, camera frame at t1) and motion (points1 - points, in double, then cast), and
    valid (bool): valid in the message, d0 > 0, d1 > 0 and every coordinate of points and
    motion within float32 range (lf_get_points3d's rule); NaN elsewhere.
    """
    fx, fy, cx, cy, baseline, cw, ch = _camera(calibration, camera)
    f = flow_arrays(msg)
    if (cw and cw != msg.image_width) or (ch and ch != msg.image_height):
        raise ValueError("calibration is for %dx%d images, the scene flow for %dx%d"
                         % (cw, ch, msg.image_width, msg.image_height))
    xs, ys = (a.astype(np.float64) for a in pixel_grid(msg))
    u, v, d0, d1 = (f[k].astype(np.float64) for k in ("u", "v", "d0", "d1"))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        fb = fx * baseline
        z0, z1 = fb / d0, fb / d1
        # Same operation order as core/points3d.hpp, so the float32 results are identical.
        p0 = np.stack([(xs - cx) * z0 / fx, (ys - cy) * z0 / fy, z0], axis=-1)
        p1 = np.stack([(xs + u - cx) * z1 / fx, (ys + v - cy) * z1 / fy, z1], axis=-1)
        motion = p1 - p0
        limit = float(np.finfo(np.float32).max)
        # The C ABI's rule (points and motion within float32 range), so the valid masks agree.
        valid = (f["valid"] & (d0 > 0) & (d1 > 0) & np.all(np.abs(p0) <= limit, axis=-1)
                 & np.all(np.abs(motion) <= limit, axis=-1))
    out = {}
    for name, a in (("points", p0), ("points1", p1), ("motion", motion)):
        a = a.astype(np.float32)
        a[~valid] = np.nan
        out[name] = a
    out["valid"] = valid
    return out


def stereo_images(msg):
    """(left, right, colour_order) of a stereo_t: uint8 arrays (height, width) for gray8, or
    (height, width, 3) in the message's channel order, which colour_order names ("rgb" or
    "bgr"; None for gray), as lidarflow.Estimator.push takes it. Row padding removed. Copies."""
    _checked(msg, stereo_t)
    bpp = stereo_t.BYTES_PER_PIXEL[msg.pixel_format]
    shape = (msg.height, msg.width) if bpp == 1 else (msg.height, msg.width, 3)
    out = []
    for raw in (msg.left, msg.right):
        rows = np.frombuffer(bytes(raw), np.uint8).reshape(msg.height, msg.row_stride)
        out.append(np.ascontiguousarray(rows[:, :msg.width * bpp]).reshape(shape))
    order = {v: k for k, v in _COLOUR.items()}.get(msg.pixel_format)
    return out[0], out[1], order


def lidar_points(msg):
    """(points, kind) of a lidar_t: float32 (N, 3) and the binding's lidar_kind ("disparity"
    or "camera"). FRAME_LIDAR points are moved into the camera frame by lidar_to_camera as the
    bridge does (double, one cast to float32), so kind is then "camera"; a transform that is not
    finite or lacks the last row 0 0 0 1, non-finite points, or points leaving float32 range
    raise MessageError, as the bridge refuses them."""
    _checked(msg, lidar_t)
    xyz = np.stack([np.asarray(msg.x, np.float32), np.asarray(msg.y, np.float32), np.asarray(msg.z, np.float32)],
                   axis=1)
    if not np.all(np.isfinite(xyz)):
        raise MessageError("lidar_t point %d is not finite" % np.flatnonzero(~np.all(np.isfinite(xyz), axis=1))[0])
    if msg.frame == lidar_t.FRAME_DISPARITY:
        return xyz, "disparity"
    if msg.frame == lidar_t.FRAME_CAMERA:
        return xyz, "camera"
    t = np.asarray(msg.lidar_to_camera, np.float64).reshape(4, 4)
    if not np.all(np.isfinite(t)):
        raise MessageError("lidar_t.lidar_to_camera is not finite")
    if not np.array_equal(t[3], [0, 0, 0, 1]):
        raise MessageError("lidar_t.lidar_to_camera's last row is %s, not 0 0 0 1" % t[3])
    p = xyz.astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        # Column by column in the bridge's order: T[r,0]*x + T[r,1]*y + T[r,2]*z + T[r,3].
        cam = np.stack([t[r, 0] * p[:, 0] + t[r, 1] * p[:, 1] + t[r, 2] * p[:, 2] + t[r, 3] for r in range(3)], axis=1)
    bad = ~np.all(np.abs(cam) <= float(np.finfo(np.float32).max), axis=1)
    if bad.any():
        raise MessageError("lidar_t point %d is out of float range after lidar_to_camera" % np.flatnonzero(bad)[0])
    return cam.astype(np.float32), "camera"


def _uint8_image(name, a):
    a = np.asarray(a)
    if a.dtype != np.uint8:
        raise ValueError("%s must have dtype uint8, got %s" % (name, a.dtype))
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] != 3):
        raise ValueError("%s must have shape (H, W) or (H, W, 3), got %s" % (name, a.shape))
    return a


def stereo_message(left, right, utime, sequence=0, frame_number=0, colour_order=None):
    """A stereo_t from uint8 arrays (H, W) gray or (H, W, 3) colour; colour needs colour_order
    "rgb" or "bgr" (no default: the wrong order silently changes the flow). Rows are packed.
    frame_number must count up by one per message of a publisher (see stereo_t.lcm)."""
    left, right = _uint8_image("left", left), _uint8_image("right", right)
    if left.shape != right.shape:
        raise ValueError("left and right differ in shape: %s and %s" % (left.shape, right.shape))
    if left.ndim == 3:
        if colour_order not in _COLOUR:
            raise ValueError("colour images need colour_order 'rgb' or 'bgr', got %r" % (colour_order,))
        fmt = _COLOUR[colour_order]
    else:
        fmt = stereo_t.PIXEL_GRAY8
    h, w = left.shape[:2]
    stride = w * stereo_t.BYTES_PER_PIXEL[fmt]
    msg = stereo_t(utime=int(utime), sequence=int(sequence), frame_number=int(frame_number), width=w, height=h,
                   row_stride=stride, pixel_format=fmt, size=stride * h,
                   left=np.ascontiguousarray(left).tobytes(), right=np.ascontiguousarray(right).tobytes())
    msg.check()
    return msg


def lidar_message(points, utime, frame="disparity", lidar_to_camera=None):
    """A lidar_t from an (N, 3) array (its first three columns): frame "disparity" (x, y pixel,
    disparity), "camera" (metres, left rectified camera frame) or "lidar" (metres, LiDAR frame;
    lidar_to_camera, a 4x4 LiDAR -> camera transform, is then required)."""
    if frame not in _LIDAR_FRAMES:
        raise ValueError("frame must be one of %s, got %r" % (sorted(_LIDAR_FRAMES), frame))
    p = np.asarray(points, dtype=np.float32)
    if p.ndim != 2 or p.shape[1] < 3:
        raise ValueError("points must have shape (N, 3) or (N, K >= 3), got %s" % (p.shape,))
    if frame == "lidar":
        if lidar_to_camera is None:
            raise ValueError('frame "lidar" needs lidar_to_camera')
        t = np.asarray(lidar_to_camera, np.float64)
        if t.shape != (4, 4):
            raise ValueError("lidar_to_camera must be 4x4, got shape %s" % (t.shape,))
    else:
        t = np.eye(4)  # lidar_t.lcm: the identity when the transform is not used
    return lidar_t(utime=int(utime), frame=_LIDAR_FRAMES[frame], lidar_to_camera=t.ravel(), num_points=p.shape[0],
                   x=p[:, 0].copy(), y=p[:, 1].copy(), z=p[:, 2].copy())


def calibration_message(fx, fy, cx, cy, baseline, utime=0, width=0, height=0):
    """A calibration_t (width/height 0: any image size)."""
    _camera({"fx": fx, "fy": fy, "cx": cx, "cy": cy, "baseline": baseline}, None)
    msg = calibration_t(utime=int(utime), width=int(width), height=int(height), fx=float(fx), fy=float(fy),
                        cx=float(cx), cy=float(cy), baseline=float(baseline))
    msg.check()
    return msg


def _to_fixed(plane):
    """bridge/wire.cpp to_fixed: round half to even at 1/64 px, saturate at +-32767, 0 for non-finite."""
    q = np.rint(plane.astype(np.float64) / float(_INT16_SCALE))
    q[~np.isfinite(q)] = 0
    return np.clip(q, -32767, 32767).astype("<i2")


def scene_flow_message(u, v, d0, d1, valid, utime=0, utime0=0, encoding="int16", step=1, **fields):
    """A scene_flow_t from full-resolution (H, W) planes (e.g. lidarflow.Estimator.result()), as
    the bridge encodes the C ABI's result: every step-th pixel, float32 or int16 at 1/64 px
    (saturating), valid as 0/1. Other scalar fields (sequence, lidar_flags, ...) by keyword."""
    if encoding not in ("float32", "int16"):
        raise ValueError("encoding must be 'float32' or 'int16', got %r" % (encoding,))
    if not (isinstance(step, numbers.Integral) and 1 <= step <= 16):
        raise ValueError("step must be an integer in 1..16, got %r" % (step,))
    planes = [np.asarray(a) for a in (u, v, d0, d1)]
    valid = np.asarray(valid)
    if valid.ndim != 2 or any(p.shape != valid.shape for p in planes):
        raise ValueError("u, v, d0, d1 and valid must be (H, W) arrays of one shape")
    h, w = valid.shape
    sub = [p[::step, ::step].astype(np.float32) for p in planes]
    if encoding == "float32":
        raw = [p.astype("<f4").tobytes() for p in sub]
        enc, scale = scene_flow_t.ENCODING_FLOAT32, 1.0
    else:
        raw = [_to_fixed(p).tobytes() for p in sub]
        enc, scale = scene_flow_t.ENCODING_INT16, float(_INT16_SCALE)
    vsub = (valid[::step, ::step] != 0).astype(np.uint8)
    msg = scene_flow_t(utime=int(utime), utime0=int(utime0), image_width=w, image_height=h, step=step,
                       width=vsub.shape[1], height=vsub.shape[0], encoding=enc, scale=scale, plane_size=len(raw[0]),
                       valid_size=vsub.size, u=raw[0], v=raw[1], d0=raw[2], d1=raw[3], valid=vsub.tobytes(), **fields)
    msg.check()
    return msg
