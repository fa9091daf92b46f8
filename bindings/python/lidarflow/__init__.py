# SPDX-License-Identifier: MIT
"""lidarflow: dense scene flow from a rectified stereo camera and a sparse LiDAR.

A pure ctypes + numpy binding of the lidarflow C ABI. Importing it loads liblidarflow (see
lidarflow._lib for where it is looked for) and checks its ABI version.

    import lidarflow
    with lidarflow.Estimator(fx, fy, cx, cy, baseline, options={"threads": 4}) as est:
        est.push(left0, right0, lidar0)
        if est.push(left1, right1, lidar1):
            r = est.result()             # numpy arrays: flow (H, W, 2), u, v, d0, d1 (NaN holes), valid, confidence

    cal = lidarflow.read_kitti_calibration("calib_cam_to_cam/000002.txt", "calib_velo_to_cam/000002.txt")
    est = lidarflow.Estimator(**cal)     # Velodyne points then go in with lidar_kind="lidar"
    cal = lidarflow.read_calibration("left.yaml,right.yaml")   # OpenCV / camera_info: docs/CALIBRATION.md

The library's messages (points dropped, fallbacks) go to the logging module's "lidarflow"
logger, silent until logging is configured. Conventions (NaN holes, flow layout, default
threads): docs/CONVENTIONS.md.
"""
try:
    import numpy as _numpy  # noqa: F401
except ImportError as _e:  # a python3 other than Debian's (pyenv, a plain venv) often lacks it
    import sys as _sys
    raise ImportError("%s needs numpy, which %s cannot import; use Debian's /usr/bin/python3 with "
                      "python3-numpy (or a venv made with /usr/bin/python3 -m venv --system-site-packages)"
                      % (__name__, _sys.executable)) from _e
from ._lib import ABI_MAJOR, lib as _lib_handle
from . import _log  # noqa: F401  (routes the library's messages to logging's "lidarflow" logger)
from .calibration import read_calibration, read_kitti_calibration
from .estimator import Estimator, LidarflowError, Quality

__version__ = _lib_handle.lf_version_string().decode()

# lf_status_t codes, for LidarflowError.status.
from ._lib import (ERR_BAD_STATE, ERR_FORMAT, ERR_INTERNAL, ERR_INVALID_ARGUMENT, ERR_IO,  # noqa: E402
                   ERR_NOT_READY, ERR_OUT_OF_MEMORY, ERR_SIZE_MISMATCH, OK)

__all__ = ["Estimator", "LidarflowError", "Quality", "read_calibration", "read_kitti_calibration", "ABI_MAJOR", "OK", "ERR_INVALID_ARGUMENT", "ERR_SIZE_MISMATCH",
           "ERR_IO", "ERR_FORMAT", "ERR_BAD_STATE", "ERR_NOT_READY", "ERR_OUT_OF_MEMORY", "ERR_INTERNAL"]
