# SPDX-License-Identifier: MIT
"""A drive's camera trajectory from its chunks: `lidarflow sequence --frames A:B` writes
poses_A-B.txt (KITTI odometry format, frame A the origin); chained chunk after chunk they give
OUT/<drive>/poses.txt with the drive's first frame as the origin, as a serial run writes it."""
import math
import os

from . import state

MAX_BYTES = 64 << 20  # a poses file of 1,000,000 frames is ~130 MB; chunks are far smaller


def chunk_file(out_dir, first, last):
    return os.path.join(out_dir, "poses_%010d-%010d.txt" % (first, last))


def _read(path):
    """The 4x4 poses (row lists) of a KITTI poses file, or None when it is not a regular file
    of at most MAX_BYTES holding rows of 12 finite numbers."""
    try:
        if not os.path.isfile(path) or os.path.getsize(path) > MAX_BYTES:
            return None
        poses = []
        with open(path) as f:
            for line in f:
                v = [float(x) for x in line.split()]
                if len(v) != 12 or not all(map(math.isfinite, v)):
                    return None
                poses.append([v[0:4], v[4:8], v[8:12], [0.0, 0.0, 0.0, 1.0]])
        return poses
    except (OSError, ValueError):
        return None


def _mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def merge(out_dir, chunks):
    """Chains the poses files of `chunks` (dicts with first/last, consecutive chunks sharing a
    frame) into out_dir/poses.txt (state.write_atomically). Returns
    (last frame written, None) or (last frame written, why the trajectory stops there)."""
    chunks = sorted(chunks, key=lambda c: c["first"])
    rows, why = [], None
    for c in chunks:
        if rows and c["first"] != chunks[0]["first"] + len(rows) - 1:
            why = "frames %d..%d are missing" % (chunks[0]["first"] + len(rows), c["first"] - 1)
            break
        local = _read(chunk_file(out_dir, c["first"], c["last"]))
        if local is None:
            why = "%s is missing or unreadable" % chunk_file(out_dir, c["first"], c["last"])
            break
        origin = rows[-1] if rows else None
        for i, p in enumerate(local):
            if i == 0 and rows:
                continue  # the shared frame: already the previous chunk's last pose
            rows.append(_mul(origin, p) if origin else p)
        if len(local) < c["last"] - c["first"] + 1:
            why = "pair %d->%d has no ego-motion" % (c["first"] + len(local) - 1, c["first"] + len(local))
            break
    if not rows:
        return None, why
    text = "".join(" ".join("%.9e" % p[i][j] for i in range(3) for j in range(4)) + "\n" for p in rows)
    state.write_atomically(os.path.join(out_dir, "poses.txt"), text.encode())
    return chunks[0]["first"] + len(rows) - 1, why
