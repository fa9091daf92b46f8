# SPDX-License-Identifier: MIT
"""ctypes declarations of the lidarflow C ABI (include/lidarflow/lidarflow.h) and the loader.

The shared library is looked for, in this order (no environment variable is needed once
lidarflow is installed):
  1. the path in the environment variable LIDARFLOW_LIBRARY (then the only candidate);
  2. next to this package (liblidarflow.so.N copied into lidarflow/, e.g. a wheel-like tree);
  3. the lib folders of the installation prefix this package sits in: for a package in
     PREFIX/lib/python3/dist-packages/lidarflow (Debian) or PREFIX/lib/python3.X/site-packages/
     lidarflow, that is PREFIX/lib and PREFIX/lib/<multiarch>;
  4. the build tree of the checkout this package sits in (build*/capi/), or, for a package
     that pip installed from a checkout's bindings/python (a venv, --user, --prefix), of that
     checkout: pip records where it came from in the package's direct_url.json (PEP 610);
  5. the system's loader by SONAME (LD_LIBRARY_PATH, ld.so.cache: /usr/lib/<multiarch>).
A copy in the package's own prefix comes before the system's, so a prefix install is not
shadowed by an older system package.
Its ABI major must equal ABI_MAJOR, else importing lidarflow raises ImportError.
"""
import ctypes
import glob
import json
import os
import urllib.parse

ABI_MAJOR = 0  # the lidarflow.h this module mirrors (LF_ABI_MAJOR)
_SONAME = "liblidarflow.so.%d" % ABI_MAJOR

# lf_status_t
OK = 0
ERR_INVALID_ARGUMENT = 1
ERR_SIZE_MISMATCH = 2
ERR_IO = 3
ERR_FORMAT = 4
ERR_BAD_STATE = 5
ERR_NOT_READY = 6
ERR_OUT_OF_MEMORY = 7
ERR_INTERNAL = 8

# lf_pixel_format_t, lf_lidar_kind_t, lf_stage_t
PIXEL_GRAY8, PIXEL_RGB8, PIXEL_BGR8 = 1, 2, 3
LIDAR_NONE, LIDAR_POINTS_CAMERA, LIDAR_POINTS_LIDAR, LIDAR_DISPARITY = 0, 1, 2, 3
STAGE_NAMES = {1: "matching", 2: "consistency", 3: "sparse", 4: "interpolation"}


class RawCamera(ctypes.Structure):
    _fields_ = [("K", ctypes.c_double * 9), ("D", ctypes.c_double * 8), ("R", ctypes.c_double * 9),
                ("P", ctypes.c_double * 12)]


class Calibration(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("has_lidar_to_camera", ctypes.c_uint32),
                ("fx", ctypes.c_double), ("fy", ctypes.c_double), ("cx", ctypes.c_double),
                ("cy", ctypes.c_double), ("baseline", ctypes.c_double),
                ("lidar_to_camera", ctypes.c_double * 16),
                ("image_width", ctypes.c_uint32), ("image_height", ctypes.c_uint32),
                ("rectify", ctypes.c_uint32), ("reserved", ctypes.c_uint32),
                ("raw_left", RawCamera), ("raw_right", RawCamera)]


class Image(ctypes.Structure):
    _fields_ = [("data", ctypes.c_void_p), ("width", ctypes.c_uint32), ("height", ctypes.c_uint32),
                ("stride_bytes", ctypes.c_uint64), ("format", ctypes.c_int32)]


class Lidar(ctypes.Structure):
    _fields_ = [("kind", ctypes.c_int32), ("count", ctypes.c_uint32), ("data", ctypes.c_void_p),
                ("stride_bytes", ctypes.c_uint64)]


class ResultInfo(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("width", ctypes.c_uint32), ("height", ctypes.c_uint32),
                ("last_stage", ctypes.c_int32), ("t0_us", ctypes.c_int64), ("t1_us", ctypes.c_int64),
                ("timing_count", ctypes.c_uint32), ("total_seconds", ctypes.c_double),
                ("rectified", ctypes.c_uint32), ("reserved", ctypes.c_uint32)]


class Plane(ctypes.Structure):
    _fields_ = [("data", ctypes.c_void_p), ("stride_bytes", ctypes.c_uint64)]


class ResultBuffers(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("width", ctypes.c_uint32), ("height", ctypes.c_uint32),
                ("u", Plane), ("v", Plane), ("d0", Plane), ("d1", Plane), ("valid", Plane),
                ("confidence", Plane)]


class Points3dBuffers(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("width", ctypes.c_uint32), ("height", ctypes.c_uint32),
                ("points", Plane), ("motion", Plane), ("valid", Plane)]


class EgoMotion(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("state", ctypes.c_int32), ("transform", ctypes.c_double * 16),
                ("inliers", ctypes.c_uint32), ("candidates", ctypes.c_uint32)]


class ObjectMotionBuffers(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("width", ctypes.c_uint32), ("height", ctypes.c_uint32),
                ("motion", Plane), ("valid", Plane)]


# lf_ego_state_t
EGO_OK = 0
EGO_STATE_NAMES = {0: "fitted", 1: "not fitted: the result comes from a stage before interpolation",
                   2: "not metric: no stereo calibration",
                   3: "not fitted: too few matches agree on one rigid background motion",
                   4: "not fitted: the rigid background model is off"}


def _prefix_lib_dirs(package_dir):
    """PREFIX/lib and PREFIX/lib/<multiarch> for the prefix whose lib/pythonX/...-packages
    holds package_dir; none when the package does not sit in such a layout."""
    parts = os.path.normpath(package_dir).split(os.sep)
    # .../PREFIX/lib/python3[.X]/{dist,site}-packages/lidarflow
    if len(parts) < 5 or parts[-2] not in ("dist-packages", "site-packages") or \
            not parts[-3].startswith("python") or parts[-4] not in ("lib", "lib64"):
        return []
    libdir = os.sep.join(parts[:-3])
    return [libdir] + sorted(d for d in glob.glob(os.path.join(libdir, "*-linux-gnu*")) if os.path.isdir(d))


def _installed_from(package_dir):
    """The checkout whose bindings/python pip installed package_dir from (its dist-info's
    direct_url.json, PEP 610), or None: not installed by pip, or not from a local folder."""
    site = os.path.dirname(package_dir)
    for record in sorted(glob.glob(os.path.join(site, "lidarflow-*.dist-info", "direct_url.json"))):
        try:
            with open(record) as f:
                url = json.load(f).get("url", "")
        except (OSError, ValueError, AttributeError):
            continue
        parsed = urllib.parse.urlparse(url)
        if parsed.scheme != "file":
            continue
        source = os.path.normpath(urllib.parse.unquote(parsed.path))  # CHECKOUT/bindings/python
        if os.path.basename(source) == "python" and os.path.basename(os.path.dirname(source)) == "bindings":
            return os.path.dirname(os.path.dirname(source))
    return None


def _candidates():
    env = os.environ.get("LIDARFLOW_LIBRARY")
    if env:
        # An explicit choice is the only candidate: silently falling back would hide mistakes.
        return [env]
    here = os.path.dirname(os.path.abspath(__file__))
    found = [os.path.join(here, _SONAME)]
    found += [os.path.join(d, _SONAME) for d in _prefix_lib_dirs(here)]
    repo = os.path.dirname(os.path.dirname(os.path.dirname(here)))  # bindings/python/lidarflow
    found += sorted(glob.glob(os.path.join(repo, "build*", "capi", _SONAME)))
    checkout = _installed_from(here)
    if checkout and checkout != repo:
        # Not built yet: the usual place still shows up in the ImportError as "no such file".
        found += sorted(glob.glob(os.path.join(checkout, "build*", "capi", _SONAME))) or \
            [os.path.join(checkout, "build", "capi", _SONAME)]
    found.append(_SONAME)  # the system loader
    return found


def _load():
    errors = []
    for path in _candidates():
        if os.sep in path and not os.path.exists(path):
            errors.append("%s: no such file" % path)
            continue
        try:
            return ctypes.CDLL(path)
        except OSError as e:
            errors.append("%s: %s" % (path, e))
    raise ImportError("lidarflow: cannot load %s (install liblidarflow, or set LIDARFLOW_LIBRARY to its "
                      "path):\n  %s"
                      % (_SONAME, "\n  ".join(errors)))


# lf_log_fn: void (*)(int32_t level, const char *message, void *user).
LOG_FN = ctypes.CFUNCTYPE(None, ctypes.c_int32, ctypes.c_char_p, ctypes.c_void_p)


# lf_quality_flag_t's bits, in order; lf_quality_name names them.
QUALITY_FLAGS = (1, 2, 4, 8, 16)


def _declare(lib):
    c = ctypes
    P = c.POINTER
    i32, u32, i64 = c.c_int32, c.c_uint32, c.c_int64
    protos = {
        "lf_status_string": (c.c_char_p, [i32]),
        "lf_version_number": (u32, []),
        "lf_version_string": (c.c_char_p, []),
        "lf_abi_major": (u32, []),
        "lf_options_create": (i32, [P(c.c_void_p)]),
        "lf_options_destroy": (None, [c.c_void_p]),
        "lf_options_set_int": (i32, [c.c_void_p, c.c_char_p, i64]),
        "lf_options_set_float": (i32, [c.c_void_p, c.c_char_p, c.c_double]),
        "lf_options_set_string": (i32, [c.c_void_p, c.c_char_p, c.c_char_p]),
        "lf_options_get_int": (i32, [c.c_void_p, c.c_char_p, P(i64)]),
        "lf_options_get_float": (i32, [c.c_void_p, c.c_char_p, P(c.c_double)]),
        "lf_options_get_string": (i32, [c.c_void_p, c.c_char_p, P(c.c_char_p)]),
        "lf_options_last_error": (c.c_char_p, [c.c_void_p]),
        "lf_create": (i32, [c.c_void_p, P(Calibration), P(c.c_void_p)]),
        "lf_destroy": (None, [c.c_void_p]),
        "lf_push_frame": (i32, [c.c_void_p, i64, P(Image), P(Image), P(Lidar)]),
        "lf_reset": (i32, [c.c_void_p]),
        "lf_flush": (i32, [c.c_void_p]),
        "lf_has_result": (i32, [c.c_void_p]),
        "lf_get_result_info": (i32, [c.c_void_p, P(ResultInfo)]),
        "lf_get_timing": (i32, [c.c_void_p, u32, P(c.c_char_p), P(c.c_double)]),
        "lf_get_result": (i32, [c.c_void_p, P(ResultBuffers)]),
        "lf_get_points3d": (i32, [c.c_void_p, P(Points3dBuffers)]),
        "lf_get_ego_motion": (i32, [c.c_void_p, P(EgoMotion)]),
        "lf_get_object_motion": (i32, [c.c_void_p, P(ObjectMotionBuffers)]),
        "lf_get_quality": (i32, [c.c_void_p, P(u32), P(c.c_char_p)]),
        "lf_quality_name": (c.c_char_p, [u32]),
        "lf_last_error": (c.c_char_p, [c.c_void_p]),
        "lf_read_kitti_calibration": (i32, [c.c_char_p, c.c_char_p, P(Calibration)]),
        "lf_read_calibration": (i32, [c.c_char_p, c.c_char_p, P(Calibration)]),
        "lf_set_log_callback": (i32, [LOG_FN, i32, c.c_void_p]),
    }
    for name, (restype, argtypes) in protos.items():
        f = getattr(lib, name)
        f.restype = restype
        f.argtypes = argtypes
    return lib


def check_abi(library, expected=ABI_MAJOR):
    """Raises ImportError unless the loaded library's ABI major is `expected`."""
    if library.lf_abi_major() != expected:
        raise ImportError("lidarflow: the loaded library %s has ABI %d, this binding needs ABI %d"
                          % (library.lf_version_string().decode(), library.lf_abi_major(), expected))


lib = _declare(_load())
check_abi(lib)
