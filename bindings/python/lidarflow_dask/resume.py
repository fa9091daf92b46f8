# SPDX-License-Identifier: MIT
"""What earlier runs into OUT completed, trusted only as far as their results are there."""
import json
import os

from . import chunks as ch
from . import results, state
from .sources import SourceError


def chunk_complete(c, done_t0s):
    """(pairs a valid marker vouches for, with its results present; or None, why not ('' when
    there is no marker))."""
    try:
        pairs = state.check_marker(ch.marker_path(c), c["first"], c["last"])
    except state.StateError as e:
        return None, "%s; recomputing the chunk" % e
    if pairs is None:
        return None, ""
    if c["kind"] == "drive":
        have = sum(1 for k in range(c["first"], c["last"]) if k in done_t0s)
    else:
        have = results.count_flows(ch.chunk_log_path(c)) or 0
    if have != pairs:
        return None, "%s was complete, but %d of its %d results are there: recomputing" % (ch.describe(c), have, pairs)
    return pairs, ""


def prepare(sources, settings):
    """Checks names and the settings recorded by an earlier run into the same folder; with
    force, forgets what earlier runs completed. Returns the chunks still to compute, the number
    of pairs already complete, and notes (markers not trusted)."""
    names = {}
    for s in sources:
        key = state.safe_name(s.name)
        if key in names:
            raise SourceError("%s and %s would both keep their state in %s: give sources distinct names"
                              % (names[key], s.path, s.state_dir()))
        names[key] = s.path
    pending, done_pairs, notes = [], 0, []
    for s in sources:
        for p in state.own_files(s.state_dir(), settings.force):
            try:
                os.unlink(p)
            except FileNotFoundError:
                pass
        if not settings.force:
            now = settings.signature(s.kind)
            try:
                old = state.check_settings(s.settings_path(), now)
            except state.StateError as e:
                raise SourceError("%s: use --force to recompute, or another --out" % e) from None
            if old is not None and old != now:
                raise SourceError("%s holds results of %s computed with other settings (%s, now %s): "
                                  "use --force to recompute, or another --out"
                                  % (settings.out, s.path, json.dumps(old), json.dumps(now)))
        done_t0s = set() if s.kind != "drive" or settings.force else \
            results.drive_complete_t0s(s.result_path(), settings.formats)
        for c in s.chunks:
            pairs, why = (None, "") if settings.force else chunk_complete(c, done_t0s)
            if why:
                notes.append(why)
            if pairs is None:
                pending.append(c)
            else:
                done_pairs += pairs
    return pending, done_pairs, notes


def record_settings(sources, pending, settings):
    """Writes the settings of each source about to get results; returns the files written."""
    made = []
    with_work = {c["source"] for c in pending}
    for s in sources:
        if s.path in with_work and (settings.force or not os.path.exists(s.settings_path())):
            os.makedirs(s.state_dir(), exist_ok=True)
            state.write_atomically(s.settings_path(), (json.dumps(settings.signature(s.kind)) + "\n").encode())
            made.append(s)
    return made
