# SPDX-License-Identifier: MIT
"""The result files a chunk leaves, checked: a drive's per-pair files, an LCM chunk's log, and
the chunk logs joined into OUT/<name>.log."""
import os

from lidarflow_lcm import CHANNELS
from lidarflow_lcm.eventlog import LogReader, LogWriter

from . import state

FLOW_CHANNEL = CHANNELS["flow"]
EGO_CHANNEL = CHANNELS["ego_motion"]  # the ego_motion_t that comes with each result
# `lidarflow sequence --format`: the files of one pair, (folder, extension), as io::result_paths.
FORMAT_FILES = {
    "kitti": (("disp_0", "png"), ("disp_1", "png"), ("flow", "png")),
    "flo": (("disp_0", "pfm"), ("disp_1", "pfm"), ("flow", "flo")),
    "pfm": (("disp_0", "pfm"), ("disp_1", "pfm"), ("flow", "pfm")),
    "npy": (("disp_0", "npy"), ("disp_1", "npy"), ("flow", "npy"), ("valid", "npy")),
}


def parse_formats(text):
    """'kitti,npy' -> ['kitti', 'npy']; ValueError for an unknown one."""
    formats = []
    for f in (text or "kitti").split(","):
        if f not in FORMAT_FILES:
            raise ValueError("--format: unknown result format '%s' (%s)" % (f, ", ".join(FORMAT_FILES)))
        if f not in formats:
            formats.append(f)
    return formats


def _files(formats):
    return sorted({ff for f in formats for ff in FORMAT_FILES[f]})


def drive_pairs_complete(out_dir, first, last, formats):
    """t0 frames in first..last-1 whose result files (every format's) all exist in out_dir."""
    files = _files(formats)
    return sum(1 for k in range(first, last)
               if all(os.path.isfile(os.path.join(out_dir, folder, "%010d.%s" % (k, ext))) for folder, ext in files))


def drive_complete_t0s(out_dir, formats):
    """Every t0 with all its result files in out_dir (one listing per folder: a whole drive)."""
    by_file = []
    for folder, ext in _files(formats):
        try:
            names = os.listdir(os.path.join(out_dir, folder))
        except OSError:
            return set()
        suffix = "." + ext
        by_file.append({int(n[:10]) for n in names if len(n) == 11 + len(ext) and n.endswith(suffix) and n[:10].isdigit()})
    return set.intersection(*by_file) if by_file else set()


def drive_has_results(out_dir):
    try:
        return any(n[:10].isdigit() for n in os.listdir(os.path.join(out_dir, "flow")))
    except OSError:
        return False


def count_flows(log, channel=FLOW_CHANNEL):
    """Scene-flow results in a result log (headers only); None when it is missing, not a regular
    file or not a readable LCM log."""
    try:
        if not os.path.isfile(log):
            return None
        with LogReader(log, channels=channel, data=False, strict=True) as r:
            return sum(1 for _ in r)
    except (OSError, ValueError):
        return None


def merge(chunk_logs, result_log):
    """Joins the chunk logs (in order) into result_log (atomically): the scene_flow_t results and
    their ego_motion_t with their log times. The chunks' status messages are left out: their
    counters are a chunk's, not the log's. Returns (results, chunk logs missing or unreadable)."""
    results, missing = 0, []

    def fill(f):
        nonlocal results
        w = LogWriter(f)
        for log in chunk_logs:
            if count_flows(log) is None:
                missing.append(log)
                continue
            with LogReader(log, channels=(FLOW_CHANNEL, EGO_CHANNEL), strict=True) as r:
                for e in r:
                    w.write(e.channel, e.data, e.utime)
                    results += e.channel == FLOW_CHANNEL

    state.write_atomically(result_log, fill)
    return results, missing
