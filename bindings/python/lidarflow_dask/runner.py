# SPDX-License-Identifier: MIT
"""Sources into chunks, chunks onto Dask (or run in order here), chunk logs into result logs."""
import os
import sys
import time

from . import chunks as ch
from . import cluster, frames, poses, results, state
from .resume import prepare, record_settings
from .settings import Settings
from .sources import Source, SourceError, detect
from .tools import ToolNotFound, check_tools

MAX_NOTES = 20  # lines of one kind of note before "... and N more"
ClusterError = cluster.ClusterError


def capped(lines, limit=MAX_NOTES):
    lines = list(lines)
    return lines[:limit] + (["... and %d more" % (len(lines) - limit)] if len(lines) > limit else [])


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
            print("chunk %s: %s, %d pairs, %.1f s on %s" % (ch.describe(c), state_text, result["pairs"],
                                                           result["seconds"], result["host"]),
                  file=self.stream, flush=True)

    def lost(self, chunk, why):
        self.add({"chunk": chunk, "host": "?", "rc": -1, "pairs": 0, "seconds": 0.0, "message": why})


def merge_logs(sources, report):
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


def merge_poses(sources, report, stream):
    """Writes OUT/<drive>/poses.txt of each drive whose chunks all completed, from their poses
    files (poses.merge); says where a trajectory stops short."""
    failed = {r["chunk"]["source"] for r in report.failed}
    for s in sources:
        if s.kind != "drive" or not s.chunks or s.path in failed:
            continue
        out_dir = ch.drive_out(s.chunks[0])
        last, why = poses.merge(out_dir, s.chunks)
        if why:
            print("lidarflow_dask: %s: %s; poses.txt %s" % (s.path, why, "not written" if last is None
                                                              else "ends at frame %d" % last), file=stream)


def check_where_chunks_run(sources, settings, client):
    """The executables, then the options, checked where the chunks will run (here, or on every
    worker and then one of them): ToolNotFound / ClusterError, ValueError for bad options."""
    kinds = {s.kind for s in sources}
    args = (settings.preset, settings.options, settings.formats, settings.threads, settings.bin_dir, settings.rig_args)
    if client is None:
        why = check_tools(kinds, settings.bin_dir)
        if why:
            raise ToolNotFound(why)
        why = ch.check_settings(*args)
    else:
        cluster.check_workers(client, kinds, settings.bin_dir)
        why = cluster.on_one_worker(client, ch.check_settings, *args)
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
            merge_logs(sources, report)
            merge_poses(sources, report, stream)
        finally:
            for s in made:
                if not s.has_results():  # nothing computed: the folder holds no results to guard
                    os.unlink(s.settings_path())
    seconds = time.monotonic() - t0
    pairs = sum(r["pairs"] for r in report.results)
    lost = sum(s.lost for s in sources)
    summary = {"sources": len(sources), "chunks": len(pending), "pairs": pairs, "pairs_complete_before": done_before,
               "failed": [(ch.describe(r["chunk"]), r["message"]) for r in report.failed], "seconds": seconds,
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
