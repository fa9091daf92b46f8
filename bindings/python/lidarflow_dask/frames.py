# SPDX-License-Identifier: MIT
"""Which frames of a source are computed, and in which chunks: `lidarflow sequence`'s rules.

Bounds: --frames A:B (A < B, at most MAX_PAIRS pairs), else a drive's lowest..highest listed
frame, refused when that spans more than MAX_PAIRS pairs (a stray file must not plan 10^9
frames). Gaps: a frame that is missing (a drive index without its image_02 file, a log index
past its end) loses the pairs on either side of it and no pair spans it, so chunks cover only
the runs of consecutive present frames; the pairs lost to gaps are reported, not planned.
"""
import os
import re

MAX_PAIRS = 1000000  # as `lidarflow sequence`: 28 hours at 10 Hz
_FRAME = re.compile(r"^(\d{10})\.png$")
_RANGE = re.compile(r"^(\d{1,10}):(\d{1,10})$")


class FramesError(ValueError):
    """Frames that cannot be planned: a bad --frames, a source without a pair, too many pairs."""


def parse_frames(text):
    """'A:B' -> (A, B) with 0 <= A < B and B - A <= MAX_PAIRS (sequence's --frames)."""
    m = _RANGE.match(text or "")
    if not m:
        raise FramesError("--frames must be A:B with frame numbers A < B, got '%s'" % text)
    a, b = int(m.group(1)), int(m.group(2))
    if a >= b:
        raise FramesError("--frames %s holds no pair (needs A < B)" % text)
    if b - a > MAX_PAIRS:
        raise FramesError("--frames %s spans more than %d pairs" % (text, MAX_PAIRS))
    return a, b


def drive_frames(path):
    """Sorted frame numbers of a drive's image_02/data/NNNNNNNNNN.png."""
    d = os.path.join(path, "image_02", "data")
    try:
        names = os.listdir(d)
    except OSError as e:
        raise FramesError("%s: cannot list: %s" % (d, e.strerror or e)) from None
    return sorted(int(m.group(1)) for m in map(_FRAME.match, names) if m)


def bounds(path, listed, frames):
    """(first, last) of a source whose present frames are `listed` (sorted), under --frames."""
    if frames:
        return frames
    if len(listed) < 2:
        raise FramesError("%s: %d frame(s), a pair needs 2" % (path, len(listed)))
    first, last = listed[0], listed[-1]
    if last - first > MAX_PAIRS:
        raise FramesError("%s spans frames %d..%d, more than %d pairs (choose a part with --frames A:B)"
                          % (path, first, last, MAX_PAIRS))
    return first, last


def runs(listed, first, last):
    """(runs, gaps) of first..last: runs of consecutive present frames (a, b), a < b, and gaps
    of missing frames (a, b), both included. A run of one frame holds no pair."""
    present = [k for k in listed if first <= k <= last]
    out, gaps, start, prev = [], [], None, None
    for k in present:
        if prev is not None and k == prev + 1:
            prev = k
            continue
        if prev is not None:
            out.append((start, prev))
            gaps.append((prev + 1, k - 1))
        elif k > first:
            gaps.append((first, k - 1))
        start = prev = k
    if prev is None:
        return [], [(first, last)]
    out.append((start, prev))
    if prev < last:
        gaps.append((prev + 1, last))
    return [r for r in out if r[0] < r[1]], gaps


def lost_pairs(gaps, first, last):
    """Pairs (t0) of first..last that touch a missing frame."""
    lost = 0
    for a, b in gaps:
        lo, hi = max(first, a - 1), min(last - 1, b)
        lost += max(0, hi - lo + 1)
    return lost


def plan(first, last, chunk):
    """Chunks of `chunk` frames from first to last; neighbours share a frame, so every pair
    (i, i+1) is in exactly one chunk."""
    out, a = [], first
    while a < last:
        b = min(a + chunk - 1, last)
        out.append((a, b))
        a = b
    return out
