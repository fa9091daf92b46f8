# SPDX-License-Identifier: MIT
"""lidarflow from Python: two stereo frames of a textured wall 5 m ahead that slides 4 px to
the right, plus a few LiDAR returns, give a dense scene flow; prints its mean and the 3-D
motion. Run with the binding on PYTHONPATH (bindings/python) and, unless the library is
installed, LIDARFLOW_LIBRARY=/path/to/liblidarflow.so.0."""
import numpy as np

import lidarflow

H, W, DISP, MOVE = 96, 320, 12, 4
rng = np.random.default_rng(1)
wall = np.kron(rng.integers(0, 256, (H // 2 + 1, (W + 64) // 2)), np.ones((2, 2))).astype(np.uint8)


def stereo_pair(move):  # a point at left x appears at x - DISP in the right image
    return wall[:H, 32 - move:32 - move + W].copy(), wall[:H, 32 - move + DISP:32 - move + DISP + W].copy()


# (x, y, disparity) of a few LiDAR returns; 3-D points work too (lidar_kind="camera"/"lidar").
lidar = np.array([[20 + 40 * i, H // 2, DISP] for i in range(8)], dtype=np.float32)

with lidarflow.Estimator(fx=300, fy=300, cx=W / 2, cy=H / 2, baseline=0.2, options={"threads": 2}) as est:
    est.push(*stereo_pair(0), lidar=lidar, timestamp=0)
    ready = est.push(*stereo_pair(MOVE), lidar=lidar, timestamp=100000)
    assert ready
    flow = {"u": np.empty((H, W), np.float32), "d0": np.empty((H, W), np.float32)}
    est.result(out=flow)  # written in place: reuse the arrays for every frame
    xyz = est.points3d()
    print("lidarflow %s: mean u %.2f px (truth %d), mean d0 %.2f px (truth %d)"
          % (lidarflow.__version__, flow["u"].mean(), MOVE, flow["d0"].mean(), DISP))
    print("mean 3-D motion [m]:", np.nanmean(xyz["motion"].reshape(-1, 3), axis=0).round(3))
