# SPDX-License-Identifier: MIT
"""Reads the scene flow results of an LCM log in Python (lidarflow_lcm; numpy only, neither
liblcm nor liblidarflow needed):

    PYTHONPATH=bindings/python /usr/bin/python3 examples/lcm_read_flow.py OUT.log [IN.log]

OUT.log: a log with scene_flow_t on LIDARFLOW_FLOW (lidarflow-lcm-bridge --replay ... --out,
or lcm-logger). IN.log (optional): a log with the calibration_t on LIDARFLOW_CALIB, for metric
3-D points. Prints one line per result."""
import sys

import numpy as np

import lidarflow_lcm as ll

calibration = None
if len(sys.argv) > 2:
    for _, msg in ll.read_messages(sys.argv[2], channels=ll.CHANNELS["calibration"]):
        calibration = msg  # the latest one

results = 0
for event, flow in ll.read_messages(sys.argv[1], channels=ll.CHANNELS["flow"]):
    a = ll.flow_arrays(flow)  # u, v, d0, d1: float32 (H, W), NaN where not valid; valid: bool
    line = "t0 %d -> t1 %d us: %dx%d (step %d), %.0f %% valid, median u %.2f px, median d0 %.2f px" % (
        flow.utime0, flow.utime, flow.width, flow.height, flow.step, 100 * a["valid"].mean(),
        np.nanmedian(a["u"]), np.nanmedian(a["d0"]))
    if calibration is not None:
        p = ll.points3d(flow, calibration)  # metres: points (t0), points1 (t1), motion
        line += ", median depth %.2f m, median motion %.3f m" % (
            np.median(p["points"][p["valid"]][:, 2]), np.median(np.linalg.norm(p["motion"][p["valid"]], axis=1)))
    print(line)
    results += 1
print("%d scene flow result(s)" % results)
sys.exit(0 if results else 1)
