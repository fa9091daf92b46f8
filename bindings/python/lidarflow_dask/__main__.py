# SPDX-License-Identifier: MIT
"""python3 -m lidarflow_dask: recorded drives and LCM logs, chunk by chunk, over a Dask cluster."""
import argparse
import logging
import os
import sys

from lidarflow_lcm import CHANNELS

from . import cluster, frames, results, rig, runner, state
from .tools import ToolNotFound

EPILOG = """\
A SOURCE is a KITTI raw drive folder (image_02/data/NNNNNNNNNN.png ...) or an LCM log; which one
is read from its content. A drive's results go to OUT/<drive name>/ (lidarflow run's layout), a
log's to OUT/<log name>.log (the scene_flow_t results, in log order). Rerunning the command
computes only the chunks not yet complete (or whose results are gone). Exit status: 0 every
pair computed; 1 some chunks failed (listed), frames missing (listed), the tools missing or
the scheduler lost; 2 bad arguments, options or sources, or OUT in use by another run. See
docs/SCALE.md.
"""


def parse(argv):
    p = argparse.ArgumentParser(prog="python3 -m lidarflow_dask", epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                description="Scene flow of recorded drives and LCM logs, in chunks of consecutive "
                                            "frames spread over a Dask cluster.")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler (tcp://host:8786)")
    where.add_argument("--workers", type=int, metavar="N",
                       help="a local cluster of N worker processes (default: 2); 0 = the serial run")
    where.add_argument("--serial", action="store_true", help="run the chunks in this process, in order, without Dask")
    p.add_argument("--threads-per-worker", type=int, default=1, metavar="K",
                   help="chunks one local worker runs at once (default 1)")
    p.add_argument("--threads-per-task", type=int, metavar="T",
                   help="estimator threads of each chunk process (default: the CPUs over the chunks running at "
                        "once on this host; 1 with --scheduler)")
    p.add_argument("--out", required=True, metavar="OUT", help="output folder (shared by every worker)")
    p.add_argument("--preset", metavar="P", help="estimator preset (lidarflow options lists them)")
    p.add_argument("--option", action="append", default=[], metavar="K=V", help="estimator option, repeatable")
    p.add_argument("--chunk", type=int, default=20, metavar="N",
                   help="frames per chunk, consecutive chunks sharing one (default 20: 19 pairs)")
    p.add_argument("--frames", metavar="A:B",
                   help="frames A..B (inclusive) of every source: pairs A->A+1 .. B-1->B, at most %d (default: "
                        "every frame; an LCM log's stereo frames count 0.. in log order)" % frames.MAX_PAIRS)
    p.add_argument("--format", default="kitti", metavar="F,..",
                   help="drives' result files: kitti (16-bit PNG, default) | flo | pfm | npy (as lidarflow sequence)")
    p.add_argument("--chunk-timeout", type=float, metavar="S",
                   help="seconds a chunk may run before it is killed and reported (default: 120 + 60 per pair; "
                        "0 = no limit)")
    p.add_argument("--warm-up", type=int, default=3, metavar="N",
                   help="each chunk's stream (drive or log) starts N frames before its first, not before the "
                        "range's first, for the priors a whole run has there (lidarflow sequence --warm-up, "
                        "lidarflow-lcm-bridge --replay --warm-up; default 3, 0 = none)")
    group = p.add_argument_group("drives' rig, instead of their calibration files (lidarflow sequence's options)",
                                 "docs/CALIBRATION.md. Each file must be there (same path) on every worker; "
                                 "relative paths are made absolute here.")
    group.add_argument("--calib", metavar="FILE[,FILE]",
                       help="KITTI calib_cam_to_cam.txt, an OpenCV stereo calibration (YAML/XML), or LEFT,RIGHT ROS "
                            "camera_info YAMLs; raw rigs are rectified")
    for key, what in (("fx", "focal length"), ("fy", "vertical focal length (default: --fx)"),
                      ("cx", "principal point column"), ("cy", "principal point row")):
        group.add_argument("--" + key, type=float, metavar="PX", help="rectified rig by numbers: " + what)
    group.add_argument("--baseline", type=float, metavar="M", help="distance of the left and right camera centres")
    group.add_argument("--strict", action="store_true",
                       help="refuse images of another size than the calibration's (default: a warning)")
    group.add_argument("--calib-velo", metavar="FILE",
                       help="Velodyne -> left camera in calib_velo_to_cam.txt's form (default: the drive's file)")
    p.add_argument("--force", action="store_true", help="recompute everything, also what is complete")
    p.add_argument("--bin-dir", metavar="DIR",
                   help="where lidarflow and lidarflow-lcm-bridge are, for every worker (default: "
                        "$LIDARFLOW_BIN_DIR, else each worker looks next to its lidarflow_dask, then on its PATH); a "
                        "build tree works")
    p.add_argument("--stereo-channel", default=CHANNELS["stereo"], metavar="NAME",
                   help="LCM logs: the stereo channel (default %s)" % CHANNELS["stereo"])
    p.add_argument("--bridge-arg", action="append", default=[], metavar="ARG",
                   help="LCM logs: an argument for lidarflow-lcm-bridge --replay, repeatable "
                        "(e.g. --bridge-arg=--lidar-channel --bridge-arg=VELO)")
    p.add_argument("sources", nargs="+", metavar="SOURCE")
    a = p.parse_args(argv)
    if a.workers is not None and a.workers < 0:
        p.error("--workers %d: 0 or more" % a.workers)
    if a.threads_per_worker < 1:
        p.error("--threads-per-worker %d: at least 1" % a.threads_per_worker)
    if a.threads_per_task is not None and a.threads_per_task < 1:
        p.error("--threads-per-task %d: at least 1" % a.threads_per_task)
    if not a.out:
        p.error("--out: the output folder must be named (got '')")
    if a.chunk_timeout is not None and not a.chunk_timeout >= 0:
        p.error("--chunk-timeout %s: seconds, 0 or more" % a.chunk_timeout)
    if not 0 <= a.warm_up <= 1000:
        p.error("--warm-up %d: frames, 0 to 1000" % a.warm_up)
    try:
        a.frames = frames.parse_frames(a.frames) if a.frames is not None else None
        a.format = results.parse_formats(a.format)
    except ValueError as e:
        p.error(str(e))
    for kv in a.option:
        if "=" not in kv or kv.startswith("="):
            p.error("--option %s: expected K=V" % kv)
    if a.stereo_channel != CHANNELS["stereo"]:
        a.bridge_arg = ["--stereo-channel", a.stereo_channel] + a.bridge_arg
    return a


def main(argv=None):
    a = parse(sys.argv[1:] if argv is None else argv)
    serial = a.serial or a.workers == 0
    workers = 0 if serial else (a.workers or 2)
    if a.threads_per_task is not None:
        threads = a.threads_per_task
    elif a.scheduler:
        threads = 1
    else:
        threads = runner.default_threads(max(1, workers), 1 if serial else a.threads_per_worker)
    try:
        # This command's choice goes to every worker (the same path on each host).
        bin_dir = a.bin_dir or os.environ.get("LIDARFLOW_BIN_DIR")
        settings = runner.Settings(a.out, preset=a.preset, options=a.option, chunk=a.chunk, threads=threads,
                                   force=a.force, bin_dir=os.path.abspath(bin_dir) if bin_dir else None,
                                   stereo_channel=a.stereo_channel, bridge_args=a.bridge_arg, formats=a.format,
                                   frames=a.frames, chunk_timeout=a.chunk_timeout, warm_up=a.warm_up,
                                   calib=a.calib, calib_velo=a.calib_velo, strict=a.strict,
                                   camera={k: getattr(a, k) for k in rig.NUMBERS})
        if serial:
            rc, _ = runner.run(a.sources, settings, client=None)
            return rc
        progress_bar = sys.stderr.isatty()
        from distributed import Client
        # The client logs tracebacks while it tries to reconnect to a scheduler gone: the run says why once.
        for name in ("distributed.client", "distributed.utils", "distributed.core", "asyncio", "tornado"):
            logging.getLogger(name).setLevel(logging.CRITICAL)
        if a.scheduler:
            with Client(a.scheduler) as client:
                rc, _ = runner.run(a.sources, settings, client=client, progress_bar=progress_bar)
            return rc
        with cluster.local_cluster(workers, a.threads_per_worker) as client:
            rc, _ = runner.run(a.sources, settings, client=client, progress_bar=progress_bar)
        return rc
    except (ValueError, state.Busy) as e:  # SourceError, bad options, unreadable state files
        print("lidarflow_dask: %s" % e, file=sys.stderr)
        return 2
    except (ToolNotFound, cluster.ClusterError, OSError) as e:
        print("lidarflow_dask: %s" % e, file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
