# SPDX-License-Identifier: MIT
"""What every chunk of a run shares, checked as it is given."""
import os

from lidarflow_lcm import CHANNELS

from . import results
from .frames import parse_frames
from .rig import rig_args


class Settings:
    """What every chunk of a run shares (see chunks.py). frames: (A, B), 'A:B' or None (every
    frame); formats: sequence's --format names (drives); chunk_timeout: seconds, None for the
    default (chunks.default_timeout), 0 for none; warm_up: frames before a chunk (back to the range's
    first) that feed its stream's priors without being written (lidarflow sequence --warm-up, the
    bridge's --replay --warm-up); calib ('FILE' or
    'LEFT,RIGHT'), calib_velo, camera ({fx, cx, cy, baseline[, fy]}), strict: the drives' rig,
    as lidarflow sequence's --calib, --calib-velo, --fx ..., --strict (rig.py)."""

    def __init__(self, out, preset=None, options=(), chunk=20, threads=1, force=False, bin_dir=None,
                 stereo_channel=CHANNELS["stereo"], bridge_args=(), formats=("kitti",), frames=None,
                 chunk_timeout=None, warm_up=3, calib=None, calib_velo=None, camera=None, strict=False):
        if not out:
            raise ValueError("--out: the output folder must be named (got '')")
        if chunk < 2:
            raise ValueError("--chunk %d: a chunk has at least 2 frames (one pair)" % chunk)
        if threads < 1:
            raise ValueError("--threads-per-task %d: at least 1" % threads)
        if chunk_timeout is not None and not chunk_timeout >= 0:
            raise ValueError("--chunk-timeout %s: seconds, 0 or more" % chunk_timeout)
        if not 0 <= warm_up <= 1000:
            raise ValueError("--warm-up %s: frames, 0 to 1000" % warm_up)
        self.out, self.preset, self.options = os.path.abspath(out), preset, list(options)
        self.chunk, self.threads, self.force, self.bin_dir = chunk, threads, force, bin_dir
        self.stereo_channel, self.bridge_args = stereo_channel, list(bridge_args)
        self.formats = results.parse_formats(",".join(formats))
        self.frames = None if frames is None else parse_frames(frames if isinstance(frames, str) else "%d:%d" % frames)
        self.chunk_timeout = chunk_timeout
        self.warm_up = warm_up
        self.rig_args, self.rig_files = rig_args(calib, calib_velo, camera, strict)

    def signature(self, kind):
        """What the results depend on; a rerun into the same folder must match it."""
        sig = {"kind": kind, "preset": self.preset, "options": self.options}
        rig = [a for a in self.rig_args if a != "--strict"]  # --strict refuses inputs, changes no result
        if kind == "drive" and rig:
            sig.update(rig=rig, rig_files=self.rig_files)
        if kind == "lcm":
            sig.update(stereo_channel=self.stereo_channel, bridge_args=self.bridge_args)
        return sig
