# SPDX-License-Identifier: MIT
"""Calibration files as Estimator arguments (lf_read_calibration / lf_read_kitti_calibration)."""
import ctypes
import os

import numpy as np

from . import _lib
from ._lib import lib


def _raw_camera(c):
    return {"K": np.array(c.K[:]).reshape(3, 3), "D": np.array(c.D[:]), "R": np.array(c.R[:]).reshape(3, 3),
            "P": np.array(c.P[:]).reshape(3, 4)}


def _read(function, path, velo_to_cam):
    from .estimator import LidarflowError  # estimator imports this module's package

    cal = _lib.Calibration()
    cal.struct_size = ctypes.sizeof(_lib.Calibration)
    velo = None if velo_to_cam is None else os.fsencode(velo_to_cam)
    status = function(os.fsencode(path), velo, ctypes.byref(cal))
    if status != _lib.OK:
        raise LidarflowError(status, lib.lf_last_error(None).decode())
    t = np.array(cal.lidar_to_camera[:], dtype=np.float64).reshape(4, 4) if cal.has_lidar_to_camera else None
    size = (cal.image_width, cal.image_height) if cal.image_width else None
    raw = {"left": _raw_camera(cal.raw_left), "right": _raw_camera(cal.raw_right)} if cal.rectify else None
    return {"fx": cal.fx, "fy": cal.fy, "cx": cal.cx, "cy": cal.cy, "baseline": cal.baseline, "lidar_to_camera": t,
            "image_size": size, "raw": raw}


def read_calibration(calibration, velo_to_cam=None):
    """dict(fx, fy, cx, cy, baseline, lidar_to_camera, image_size, raw) for Estimator(**cal).

    calibration: a KITTI calib_cam_to_cam.txt, an OpenCV stereo calibration file (YAML or XML:
    M1 D1 M2 D2 R T, R1 R2 P1 P2 when present) or "left.yaml,right.yaml", two ROS camera_info
    files (docs/CALIBRATION.md). fx ... baseline describe the rectified pair; image_size is
    (width, height) or None when the source has none; raw is None for a rectified rig, else
    {"left": {K, D, R, P}, "right": {...}} (numpy arrays) with which the Estimator rectifies
    each pair. velo_to_cam: optional calib_velo_to_cam.txt into the raw left camera; then
    lidar_to_camera is the 4x4 LiDAR -> rectified left camera transform, else None. Raises
    LidarflowError (ERR_IO for an unreadable file, ERR_FORMAT for a malformed one).
    """
    return _read(lib.lf_read_calibration, calibration, velo_to_cam)


def read_kitti_calibration(cam_to_cam, velo_to_cam=None):
    """read_calibration for KITTI files only (lf_read_kitti_calibration): cam_to_cam is a
    calib_cam_to_cam.txt, velo_to_cam an optional calib_velo_to_cam.txt (lidar_to_camera then
    composes R_rect_00 and camera 2's offset); image_size from S_rect_02; raw is None."""
    return _read(lib.lf_read_kitti_calibration, cam_to_cam, velo_to_cam)
