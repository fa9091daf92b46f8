# SPDX-License-Identifier: MIT
"""Sources into chunks, chunks onto Dask (or run in order here), chunk logs into result logs."""
import json
import os
import sys
import time

from lidarflow_lcm.eventlog import SYNC, LogReader

from . import chunks as ch
from . import cluster, frames, results, state
from .frames import parse_frames
from .tools import ToolNotFound, check_tools

_SYNC_BYTES = SYNC.to_bytes(4, "big")
MAX_NOTES = 20  # lines of one kind of note before "... and N more"


class SourceError(ValueError):
    """A source that is neither a drive nor an LCM log, has no pair of frames, or clashes with
    another source or with OUT."""


ClusterError = cluster.ClusterError


class Settings:
    """What every chunk of a run shares (see chunks.py). frames: (A, B), 'A:B' or None (every
    frame); formats: sequence's --format names (drives); chunk_timeout: seconds, None for the
    default (chunks.default_timeout), 0 for none."""

    def __init__(self, out, preset=None, options=(), chunk=20, threads=1, force=False, bin_dir=None,
                 stereo_channel="LIDARFLOW_STEREO", bridge_args=(), formats=("kitti",), frames=None,
                 chunk_timeout=None):
        if not out:
            raise ValueError("--out: the output folder must be named (got '')")
        if chunk < 2:
            raise ValueError("--chunk %d: a chunk has at least 2 frames (one pair)" % chunk)
        if threads < 1:
            raise ValueError("--threads-per-task %d: at least 1" % threads)
        if chunk_timeout is not None and not chunk_timeout >= 0:
            raise ValueError("--chunk-timeout %s: seconds, 0 or more" % chunk_timeout)
        self.out, self.preset, self.options = os.path.abspath(out), preset, list(options)
        self.chunk, self.threads, self.force, self.bin_dir = chunk, threads, force, bin_dir
        self.stereo_channel, self.bridge_args = stereo_channel, list(bridge_args)
        self.formats = results.parse_formats(",".join(formats))
        self.frames = parse_frames(frames) if isinstance(frames, str) else frames
        self.chunk_timeout = chunk_timeout

    def signature(self, kind):
        """What the results depend on; a rerun into the same folder must match it."""
        sig = {"kind": kind, "preset": self.preset, "options": self.options}
        if kind == "lcm":
            sig.update(stereo_channel=self.stereo_channel, bridge_args=self.bridge_args)
        return sig



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
                self.chunks.append({"kind": self.kind, "source": self.path, "name": self.name, "first": a, "last": b,
                                    "out": settings.out, "preset": settings.preset, "options": settings.options,
                                    "formats": settings.formats, "threads": settings.threads,
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


def capped(lines, limit=MAX_NOTES):
    lines = list(lines)
    return lines[:limit] + (["... and %d more" % (len(lines) - limit)] if len(lines) > limit else [])


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
        return None, "%s frames %d:%d was complete, but %d of its %d results are there: recomputing" \
            % (c["source"], c["first"], c["last"], have, pairs)
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
            try:
                old = state.check_settings(s.settings_path(), settings.signature(s.kind))
            except state.StateError as e:
                raise SourceError("%s: use --force to recompute, or another --out" % e) from None
            if old is not None and old != settings.signature(s.kind):
                raise SourceError("%s holds results of %s computed with other settings (%s, now %s): "
                                  "use --force to recompute, or another --out"
                                  % (settings.out, s.path, old, settings.signature(s.kind)))
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


def describe(chunk):
    return "%s frames %d:%d" % (chunk["source"], chunk["first"], chunk["last"])


class Report:
    """Collects the chunk results: a line per chunk (when asked) and the final summary."""

    def __init__(self, stream, lines):
        self.stream, self.lines = stream, lines
        self.results, self.failed = [], []

    def add(self, result):
        self.results.append(result)
        c = result["chunk"]
        if result["rc"] != 0:
            self.failed.append(result)
        if self.lines:
            state_text = "ok" if result["rc"] == 0 else "FAILED"
            print("chunk %s: %s, %d pairs, %.1f s on %s" % (describe(c), state_text, result["pairs"],
                                                           result["seconds"], result["host"]),
                  file=self.stream, flush=True)

    def lost(self, chunk, why):
        self.add({"chunk": chunk, "host": "?", "rc": -1, "pairs": 0, "seconds": 0.0, "message": why})


def merge_logs(sources, report, settings):
    """Writes the result log of each LCM source whose chunks changed or whose result log is not
    the chunks' results; a chunk log lost since its chunk completed is reported as failed."""
    computed = {(r["chunk"]["source"], r["chunk"]["first"]) for r in report.results}
    failed = {(r["chunk"]["source"], r["chunk"]["first"]) for r in report.failed}
    for s in sources:
        if s.kind != "lcm" or not s.chunks:
            continue
        expected = sum(c["last"] - c["first"] for c in s.chunks)
        if not any((s.path, c["first"]) in computed for c in s.chunks) and \
                results.count_flows(s.result_path()) == expected:
            continue
        _, missing = results.merge([ch.chunk_log_path(c) for c in s.chunks], s.result_path())
        for c in s.chunks:
            if ch.chunk_log_path(c) in missing and (s.path, c["first"]) not in failed:
                report.lost(c, "its chunk log %s is missing or unreadable at the merge into %s"
                            % (ch.chunk_log_path(c), s.result_path()))


def check_where_chunks_run(sources, settings, client):
    """The executables, then the options, checked where the chunks will run (here, or on every
    worker and then one of them): ToolNotFound / ClusterError, ValueError for bad options."""
    kinds = {s.kind for s in sources}
    if client is None:
        why = check_tools(kinds, settings.bin_dir)
        if why:
            raise ToolNotFound(why)
        why = ch.check_settings(settings.preset, settings.options, settings.formats, settings.threads, settings.bin_dir)
    else:
        cluster.check_workers(client, kinds, settings.bin_dir)
        why = cluster.on_one_worker(client, ch.check_settings, settings.preset, settings.options, settings.formats,
                                    settings.threads, settings.bin_dir)
    if why:
        raise ValueError(why)


def run(source_paths, settings, client=None, stream=sys.stderr, progress_bar=False):
    """Runs every chunk not yet complete (on `client`, or in order here when None), then writes
    the LCM sources' result logs. Returns (exit status, summary dict); prints the summary.
    Raises SourceError / ValueError (bad sources or settings), state.Busy (another run into
    OUT), ToolNotFound, ClusterError."""
    t0 = time.monotonic()
    sources = [Source(p, settings) for p in source_paths]
    check_where_chunks_run(sources, settings, client)
    with state.Lock(settings.out):
        pending, done_before, notes = prepare(sources, settings)
        for line in capped(notes):
            print("lidarflow_dask: %s" % line, file=stream)
        n_chunks = sum(len(s.chunks) for s in sources)
        print("lidarflow_dask: %d source(s), %d chunk(s) of up to %d frames, %d to compute (%d complete), %s"
              % (len(sources), n_chunks, settings.chunk, len(pending), n_chunks - len(pending),
                 "serial" if client is None else "on %d Dask worker(s)" % len(client.scheduler_info()["workers"])),
              file=stream, flush=True)
        report = Report(stream, lines=client is None or not progress_bar)
        made = record_settings(sources, pending, settings)
        try:
            if pending and client is None:
                for c in pending:
                    report.add(ch.run_chunk(c))
            elif pending:
                cluster.run_dask(pending, report, client, progress_bar)
            merge_logs(sources, report, settings)
        finally:
            for s in made:
                if not s.has_results():  # nothing computed: the folder holds no results to guard
                    os.unlink(s.settings_path())
    seconds = time.monotonic() - t0
    pairs = sum(r["pairs"] for r in report.results)
    lost = sum(s.lost for s in sources)
    summary = {"sources": len(sources), "chunks": len(pending), "pairs": pairs, "pairs_complete_before": done_before,
               "failed": [(describe(r["chunk"]), r["message"]) for r in report.failed], "seconds": seconds,
               "pairs_per_second": pairs / seconds if seconds > 0 else 0.0, "pairs_missing_frames": lost}
    for line in capped("%s: %s" % (what, why.replace("\n", "\n    ")) for what, why in summary["failed"]):
        print("FAILED: %s" % line, file=stream)
    for line in capped(s.missing_text(g) for s in sources for g in s.gaps):
        print("MISSING: %s" % line, file=stream)
    print("lidarflow_dask: %d pairs computed in %.1f s (%.2f pairs/s), %d complete before; %d of %d chunks failed%s%s"
          % (pairs, seconds, summary["pairs_per_second"], done_before, len(report.failed), len(pending),
             "; %d pairs not computed for missing frames" % lost if lost else "",
             " (rerun the command to retry them)" if report.failed else ""), file=stream, flush=True)
    return (1 if report.failed or lost else 0), summary


def default_threads(workers, threads_per_worker):
    """Estimator threads per chunk: the CPUs shared by the chunks running at once."""
    return max(1, (os.cpu_count() or 1) // max(1, workers * threads_per_worker))


plan = frames.plan

__all__ = ["ClusterError", "Settings", "Source", "SourceError", "detect", "plan", "run", "default_threads"]
