# SPDX-License-Identifier: MIT
"""A source (a drive folder or an LCM log): its kind, its name in OUT, its frames and chunks."""
import os

from lidarflow_lcm.eventlog import SYNC, LogReader

from . import chunks as ch
from . import frames, results, state

_SYNC_BYTES = SYNC.to_bytes(4, "big")


class SourceError(ValueError):
    """A source that is neither a drive nor an LCM log, has no pair of frames, or clashes with
    another source or with OUT."""


def detect(path):
    """'drive' (a folder with image_02/data/*.png, KITTI raw) or 'lcm' (a file starting with
    the LCM sync word), from the content; SourceError otherwise."""
    if os.path.isdir(path):
        if os.path.isdir(os.path.join(path, "image_02", "data")):
            return "drive"
        raise SourceError("%s: a folder without image_02/data/ (not a KITTI raw drive)" % path)
    try:
        with open(path, "rb") as f:
            head = f.read(4)
    except OSError as e:
        raise SourceError("%s: %s" % (path, e.strerror or e)) from None
    if head == _SYNC_BYTES:
        return "lcm"
    raise SourceError("%s: neither a drive folder nor an LCM log (no LCM sync word at its start)" % path)


def listed_frames(kind, path, stereo_channel):
    """The source's present frames: a drive's image_02 indices, an LCM log's stereo events
    0..N-1 in log order (as the bridge's --frames counts them)."""
    if kind == "drive":
        return frames.drive_frames(path)
    with LogReader(path, channels=stereo_channel, data=False) as log:
        return range(sum(1 for _ in log))


def source_name(path):
    base = os.path.basename(os.path.normpath(path))
    return base[:-4] if base.endswith(".log") else base


class Source:
    def __init__(self, path, settings):
        self.path = os.path.abspath(path)
        self.kind = detect(self.path)
        self.name = source_name(self.path)
        self.out = settings.out
        if not self.name or (self.kind == "drive" and self.name == state.STATE_DIR):
            raise SourceError("%s: a source needs a name of its own in %s (got '%s')" % (self.path, self.out, self.name))
        if os.path.abspath(self.result_path()) == self.path:
            raise SourceError("%s: its results would overwrite it (--out %s is its folder)" % (self.path, self.out))
        if self.kind == "lcm" and settings.rig_args:
            raise SourceError("%s: an LCM log carries its calibration; --calib, --calib-velo, --fx ... and --strict "
                              "are for drives (a log's fixed calibration: --bridge-arg=--calib --bridge-arg=FILE)"
                              % self.path)
        listed = listed_frames(self.kind, self.path, settings.stereo_channel)
        try:
            self.first, self.last = frames.bounds(self.path, listed, settings.frames)
        except frames.FramesError as e:
            raise SourceError(str(e)) from None
        present, self.gaps = frames.runs(listed, self.first, self.last)
        self.lost = frames.lost_pairs(self.gaps, self.first, self.last)
        self.chunks = []
        for r0, r1 in present:
            for a, b in frames.plan(r0, r1, settings.chunk):
                # Not before the range's first frame, where the serial run (and the first chunk) starts cold.
                warm_up = min(settings.warm_up, a - self.first)
                self.chunks.append({"kind": self.kind, "source": self.path, "name": self.name, "first": a, "last": b,
                                    "out": settings.out, "preset": settings.preset, "options": settings.options,
                                    "formats": settings.formats, "threads": settings.threads,
                                    "rig_args": settings.rig_args,
                                    "warm_up": warm_up,
                                    "force": settings.force, "bin_dir": settings.bin_dir,
                                    "stereo_channel": settings.stereo_channel, "bridge_args": settings.bridge_args,
                                    "timeout": ch.default_timeout(b - a) if settings.chunk_timeout is None
                                    else settings.chunk_timeout})

    def result_path(self):
        """OUT/<name>/ of a drive, OUT/<name>.log of a log."""
        return os.path.join(self.out, self.name + (".log" if self.kind == "lcm" else ""))

    def state_dir(self):
        return state.state_dir(self.out, self.name)

    def settings_path(self):
        return os.path.join(self.state_dir(), "settings.json")

    def has_results(self):
        if self.kind == "drive":
            return results.drive_has_results(self.result_path())
        try:
            return any(state.CHUNK_FILE.match(n) and n.endswith(".log") for n in os.listdir(self.state_dir()))
        except OSError:
            return False

    def missing_text(self, gap):
        what = "no image_02/data/NNNNNNNNNN.png" if self.kind == "drive" else "past the log's last stereo frame"
        return "%s frames %d..%d: %s" % (self.path, gap[0], gap[1], what)
