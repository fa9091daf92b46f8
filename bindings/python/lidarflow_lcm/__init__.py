# SPDX-License-Identifier: MIT
"""lidarflow_lcm: the lidarflow LCM messages in pure Python (numpy only; neither liblcm nor
liblidarflow is needed).

    import lidarflow_lcm as ll
    for event, flow in ll.read_messages("out.log", channels="LIDARFLOW_FLOW"):
        a = ll.flow_arrays(flow)                   # u, v, d0, d1 (NaN where invalid), valid
        xyz = ll.points3d(flow, calibration)       # calibration_t or fx, fy, cx, cy, baseline

Message classes stereo_t, lidar_t, calibration_t, scene_flow_t, status_t, ego_motion_t and quality_t encode and decode
the bytes of lcm-gen's C/C++ code (same fingerprints) and refuse malformed input with
MessageError. LogReader / LogWriter read and write LCM event logs. The package name differs
from the `lidarflow` binding on purpose: `lcm-gen -p` would name these types `lidarflow` too.
"""
try:
    import numpy as _numpy  # noqa: F401
except ImportError as _e:  # a python3 other than Debian's (pyenv, a plain venv) often lacks it
    import sys as _sys
    raise ImportError("%s needs numpy, which %s cannot import; use Debian's /usr/bin/python3 with "
                      "python3-numpy (or a venv made with /usr/bin/python3 -m venv --system-site-packages)"
                      % (__name__, _sys.executable)) from _e
from .arrays import (calibration_message, flow_arrays, lidar_message, lidar_points, pixel_grid, points3d,
                     scene_flow_message, stereo_images, stereo_message)
from .eventlog import Event, LogFormatError, LogReader, LogWarning, LogWriter, read_messages
from .messages import (TYPES, MessageError, calibration_t, decode, ego_motion_t, lidar_t, quality_t, scene_flow_t,
                       status_t, stereo_t, type_of)

# The channels lidarflow-lcm-bridge and `lidarflow publish-kitti` use by default (docs/LCM.md).
CHANNELS = {"stereo": "LIDARFLOW_STEREO", "lidar": "LIDARFLOW_LIDAR", "calibration": "LIDARFLOW_CALIB",
            "flow": "LIDARFLOW_FLOW", "status": "LIDARFLOW_STATUS", "ego_motion": "LIDARFLOW_EGO_MOTION", "quality": "LIDARFLOW_QUALITY"}

__all__ = ["stereo_t", "lidar_t", "calibration_t", "scene_flow_t", "status_t", "ego_motion_t", "quality_t", "TYPES", "MessageError", "decode",
           "type_of", "Event", "LogReader", "LogWriter", "LogFormatError", "LogWarning", "read_messages",
           "flow_arrays", "pixel_grid", "points3d", "stereo_images", "lidar_points", "stereo_message", "lidar_message",
           "calibration_message", "scene_flow_message", "CHANNELS"]
