# SPDX-License-Identifier: MIT
"""lidarflow_dask: recorded drives and LCM logs, in chunks, over a Dask cluster.

A task is one chunk of consecutive frames of one source, computed by the project's own
executables in a subprocess: `lidarflow sequence --frames A:B` for a drive,
`lidarflow-lcm-bridge --replay LOG --frames A:B` for an LCM log. So the results are those of
the one C++ implementation, and one chunk process keeps one estimator (descriptors reused from
frame to frame within the chunk). Neighbouring chunks share a frame: every pair is computed once.

    python3 -m lidarflow_dask --workers 2 --out OUT drive_0001_sync/ run.log

From Python (client: a distributed.Client, or None for the serial run in this process):

    import lidarflow_dask
    rc, summary = lidarflow_dask.run(["drive/"], lidarflow_dask.Settings("OUT", preset="realtime"), client)

Thread-safety: run() takes a lock on the output folder (a second run into it, from any process
or host sharing it, is refused with Busy naming the holder); run_chunk() runs
concurrently on any number of workers (each writes files under names of its own and renames them).
"""
from .chunks import run_chunk
from .results import merge
from .runner import ClusterError, Settings, Source, SourceError, default_threads, detect, plan, run
from .state import Busy
from .tools import ToolNotFound, find_tool

__all__ = ["Busy", "ClusterError", "Settings", "Source", "SourceError", "ToolNotFound", "default_threads", "detect",
           "find_tool", "merge", "plan", "run", "run_chunk"]
