# SPDX-License-Identifier: MIT
"""Sources into chunks, chunks onto Dask (or run in order here), chunk logs into result logs."""
import json
import os
import re
import sys
import time

from lidarflow_lcm.eventlog import SYNC, LogReader, LogWriter

from . import chunks as ch

_FRAME = re.compile(r"^(\d{10})\.png$")
_SYNC_BYTES = SYNC.to_bytes(4, "big")


class SourceError(ValueError):
    """A source that is neither a drive nor an LCM log, or has no pair of frames."""


class ClusterError(RuntimeError):
    """No worker, or workers that cannot run the chunks (the executables or lidarflow_dask missing)."""


class Settings:
    """What every chunk of a run shares (see chunks.py)."""

    def __init__(self, out, preset=None, options=(), chunk=20, threads=1, force=False, bin_dir=None,
                 stereo_channel="LIDARFLOW_STEREO", bridge_args=()):
        if chunk < 2:
            raise ValueError("--chunk %d: a chunk has at least 2 frames (one pair)" % chunk)
        if threads < 1:
            raise ValueError("--threads-per-task %d: at least 1" % threads)
        self.out, self.preset, self.options = os.path.abspath(out), preset, list(options)
        self.chunk, self.threads, self.force, self.bin_dir = chunk, threads, force, bin_dir
        self.stereo_channel, self.bridge_args = stereo_channel, list(bridge_args)

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


def frame_range(kind, path, stereo_channel):
    """(first, last) frame numbers of a source: a drive's lowest and highest image_02 index, an
    LCM log's stereo events 0..N-1 in log order (as the bridge's --frames counts them)."""
    if kind == "drive":
        idx = [int(m.group(1)) for m in map(_FRAME.match, os.listdir(os.path.join(path, "image_02", "data"))) if m]
        if len(idx) < 2:
            raise SourceError("%s: %d frame(s) in image_02/data/, a pair needs 2" % (path, len(idx)))
        return min(idx), max(idx)
    with LogReader(path, channels=stereo_channel, data=False) as log:
        n = sum(1 for _ in log)
    if n < 2:
        raise SourceError("%s: %d stereo frame(s) on %s, a pair needs 2" % (path, n, stereo_channel))
    return 0, n - 1


def plan(first, last, chunk):
    """Chunks of `chunk` frames from first to last; neighbours share a frame, so every pair
    (i, i+1) is in exactly one chunk."""
    out, a = [], first
    while a < last:
        b = min(a + chunk - 1, last)
        out.append((a, b))
        a = b
    return out


def source_name(path):
    base = os.path.basename(os.path.normpath(path))
    return base[:-4] if base.endswith(".log") else base


class Source:
    def __init__(self, path, settings):
        self.path = os.path.abspath(path)
        self.kind = detect(self.path)
        self.name = source_name(self.path)
        self.first, self.last = frame_range(self.kind, self.path, settings.stereo_channel)
        self.chunks = []
        for a, b in plan(self.first, self.last, settings.chunk):
            self.chunks.append({"kind": self.kind, "source": self.path, "name": self.name, "first": a, "last": b,
                                "out": settings.out, "preset": settings.preset, "options": settings.options,
                                "threads": settings.threads, "force": settings.force, "bin_dir": settings.bin_dir,
                                "stereo_channel": settings.stereo_channel, "bridge_args": settings.bridge_args})

    def result_log(self, out):
        return os.path.join(out, self.name + ".log")


def prepare(sources, settings):
    """Checks names and the settings recorded by an earlier run into the same folder; with
    force, forgets what earlier runs completed. Returns the chunks still to compute and the
    number of pairs already complete."""
    names = {}
    for s in sources:
        if s.name in names:
            raise SourceError("%s and %s would both write %s/%s: give sources distinct names"
                              % (names[s.name], s.path, settings.out, s.name))
        names[s.name] = s.path
    pending, done_pairs = [], 0
    for s in sources:
        d = ch.state_dir(settings.out, s.name)
        os.makedirs(d, exist_ok=True)
        sig_path, sig = os.path.join(d, "settings.json"), settings.signature(s.kind)
        for n in os.listdir(d):
            # Left by attempts that died; one run per output folder at a time.
            if ".tmp." in n or (settings.force and (n.endswith(".done") or n.endswith(".log"))):
                os.unlink(os.path.join(d, n))
        if not settings.force and os.path.exists(sig_path):
            with open(sig_path) as f:
                old = json.load(f)
            if old != sig:
                raise SourceError("%s holds results of %s computed with other settings (%s, now %s): "
                                  "use --force to recompute, or another --out"
                                  % (settings.out, s.path, json.dumps(old), json.dumps(sig)))
        ch.write_atomically(sig_path, (json.dumps(sig) + "\n").encode())
        for c in s.chunks:
            if os.path.exists(ch.marker_path(c)):
                with open(ch.marker_path(c)) as f:
                    done_pairs += json.load(f)["pairs"]
            else:
                pending.append(c)
    return pending, done_pairs


def merge(source, out):
    """Concatenates a log source's chunk logs in chunk order into OUT/<name>.log (atomically):
    the scene_flow_t results and their ego_motion_t with their log times, renumbered. The chunks'
    status messages are left out: their counters are a chunk's, not the log's. Returns (results,
    chunks missing)."""
    results, missing = 0, []

    def fill(f):
        nonlocal results
        w = LogWriter(f)
        for c in source.chunks:
            log = ch.chunk_log_path(c)
            if not os.path.exists(log):
                missing.append(c)
                continue
            with LogReader(log, channels=(ch.FLOW_CHANNEL, ch.EGO_CHANNEL), strict=True) as r:
                for e in r:
                    w.write(e.channel, e.data, e.utime)
                    results += e.channel == ch.FLOW_CHANNEL

    ch.write_atomically(source.result_log(out), fill)
    return results, missing


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
            state = "ok" if result["rc"] == 0 else "FAILED"
            print("chunk %s: %s, %d pairs, %.1f s on %s" % (describe(c), state, result["pairs"], result["seconds"],
                                                           result["host"]), file=self.stream, flush=True)

    def lost(self, chunk, why):
        self.add({"chunk": chunk, "host": "?", "rc": -1, "pairs": 0, "seconds": 0.0, "message": why})


def run_serial(pending, report):
    for c in pending:
        report.add(ch.run_chunk(c))


def run_dask(pending, report, client, progress_bar):
    from distributed import as_completed, progress
    # pure=False: a rerun after a failure is a new task, not the cached failed one.
    futures = client.map(ch.run_chunk, pending, pure=False, key=["lidarflow-%s-%s" % (c["name"], ch.chunk_key(c))
                                                              for c in pending])
    chunk_of = {f.key: c for f, c in zip(futures, pending)}
    if progress_bar:
        progress(futures)
        print(file=report.stream)
    for f in as_completed(futures):
        if f.status == "finished":
            report.add(f.result())
        else:
            # e.g. KilledWorker: the chunk took down workers more often than Dask allows.
            report.lost(chunk_of[f.key], "%s: %s" % (f.status, f.exception()))


def check_workers(client, kinds, bin_dir):
    """The executables on every worker; {worker: why} for those without them."""
    answers = client.run(ch.check_tools, sorted(kinds), bin_dir, on_error="return")
    bad = {}
    for w, why in answers.items():
        if isinstance(why, BaseException):  # e.g. lidarflow_dask not importable there
            bad[w] = "%s: %s (install python3-lidarflow-dask on every worker host)" % (type(why).__name__, why)
        elif why:
            bad[w] = why
    return bad


def run(source_paths, settings, client=None, stream=sys.stderr, progress_bar=False):
    """Runs every chunk not yet complete (on `client`, or in order here when None), then writes
    the LCM sources' result logs. Returns (exit status, summary dict); prints the summary."""
    t0 = time.monotonic()
    sources = [Source(p, settings) for p in source_paths]
    pending, done_before = prepare(sources, settings)
    kinds = {s.kind for s in sources}
    if client is None:
        why = ch.check_tools(kinds, settings.bin_dir)
        if why:
            raise ch.ToolNotFound(why)
    else:
        # Workers started just before may not have joined yet: the check needs at least one.
        try:
            client.wait_for_workers(1, timeout=120)
        except TimeoutError:
            raise ClusterError("no Dask worker joined the scheduler within 120 s") from None
        bad = check_workers(client, kinds, settings.bin_dir)
        if bad:
            raise ClusterError("; ".join("worker %s: %s" % kv for kv in sorted(bad.items())))
    print("lidarflow_dask: %d source(s), %d chunk(s) of up to %d frames, %d to compute (%d complete), %s"
          % (len(sources), sum(len(s.chunks) for s in sources), settings.chunk, len(pending),
             sum(len(s.chunks) for s in sources) - len(pending),
             "serial" if client is None else "on %d Dask worker(s)" % len(client.scheduler_info()["workers"])),
          file=stream, flush=True)
    report = Report(stream, lines=client is None or not progress_bar)
    if pending:
        if client is None:
            run_serial(pending, report)
        else:
            run_dask(pending, report, client, progress_bar)
    computed = {(r["chunk"]["source"], r["chunk"]["first"]) for r in report.results}
    for s in sources:
        if s.kind == "lcm" and (not os.path.exists(s.result_log(settings.out)) or
                                any((s.path, c["first"]) in computed for c in s.chunks)):
            merge(s, settings.out)
    seconds = time.monotonic() - t0
    pairs = sum(r["pairs"] for r in report.results)
    summary = {"sources": len(sources), "chunks": len(pending), "pairs": pairs, "pairs_complete_before": done_before,
               "failed": [(describe(r["chunk"]), r["message"]) for r in report.failed], "seconds": seconds,
               "pairs_per_second": pairs / seconds if seconds > 0 else 0.0}
    for what, why in summary["failed"]:
        print("FAILED: %s: %s" % (what, why.replace("\n", "\n    ")), file=stream)
    print("lidarflow_dask: %d pairs computed in %.1f s (%.2f pairs/s), %d complete before; %d of %d chunks failed%s"
          % (pairs, seconds, summary["pairs_per_second"], done_before, len(report.failed), len(pending),
             " (rerun the command to retry them)" if report.failed else ""), file=stream, flush=True)
    return (1 if report.failed else 0), summary


def default_threads(workers, threads_per_worker):
    """Estimator threads per chunk: the CPUs shared by the chunks running at once."""
    return max(1, (os.cpu_count() or 1) // max(1, workers * threads_per_worker))


__all__ = ["ClusterError", "Settings", "Source", "SourceError", "detect", "plan", "merge", "run", "default_threads"]
