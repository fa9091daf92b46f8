# SPDX-License-Identifier: MIT
"""KITTI calibration files as Estimator arguments (lf_read_kitti_calibration in lidarflow.h)."""
import ctypes
import os

import numpy as np

from . import _lib
from ._lib import lib


def read_kitti_calibration(cam_to_cam, velo_to_cam=None):
    """dict(fx, fy, cx, cy, baseline, lidar_to_camera) for Estimator(**cal).

    cam_to_cam: path of a KITTI calib_cam_to_cam.txt (intrinsics and baseline of the rectified
    colour pair 2/3). velo_to_cam: optional calib_velo_to_cam.txt; then lidar_to_camera is the
    4x4 float64 Velodyne -> left rectified camera transform (R_rect_00 and camera 2's offset
    composed in), as lidar_kind="lidar" expects; else None. Raises LidarflowError (ERR_IO for
    an unreadable file, ERR_FORMAT for a malformed one).
    """
    from .estimator import LidarflowError  # estimator imports this module's package

    cal = _lib.Calibration()
    cal.struct_size = ctypes.sizeof(_lib.Calibration)
    velo = None if velo_to_cam is None else os.fsencode(velo_to_cam)
    status = lib.lf_read_kitti_calibration(os.fsencode(cam_to_cam), velo, ctypes.byref(cal))
    if status != _lib.OK:
        raise LidarflowError(status, lib.lf_last_error(None).decode())
    t = np.array(cal.lidar_to_camera[:], dtype=np.float64).reshape(4, 4) if cal.has_lidar_to_camera else None
    return {"fx": cal.fx, "fy": cal.fy, "cx": cal.cx, "cy": cal.cy, "baseline": cal.baseline, "lidar_to_camera": t}
