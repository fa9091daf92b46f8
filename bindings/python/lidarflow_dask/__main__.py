# SPDX-License-Identifier: MIT
"""python3 -m lidarflow_dask: recorded drives and LCM logs, chunk by chunk, over a Dask cluster."""
import argparse
import os
import sys

from . import chunks, runner

EPILOG = """\
A SOURCE is a KITTI raw drive folder (image_02/data/NNNNNNNNNN.png ...) or an LCM log; which one
is read from its content. A drive's results go to OUT/<drive name>/ (lidarflow run's layout), a
log's to OUT/<log name>.log (the scene_flow_t results, in log order). Rerunning the command
computes only the chunks not yet complete. Exit status: 0 every chunk complete, 1 some chunks
failed (listed), 2 bad arguments or sources. See docs/SCALE.md.
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
    p.add_argument("--force", action="store_true", help="recompute everything, also what is complete")
    p.add_argument("--bin-dir", metavar="DIR",
                   help="where lidarflow and lidarflow-lcm-bridge are, for every worker (default: "
                        "$LIDARFLOW_BIN_DIR, else each worker looks next to its lidarflow_dask, then on its PATH); a "
                        "build tree works")
    p.add_argument("--stereo-channel", default="LIDARFLOW_STEREO", metavar="NAME",
                   help="LCM logs: the stereo channel (default LIDARFLOW_STEREO)")
    p.add_argument("--bridge-arg", action="append", default=[], metavar="ARG",
                   help="LCM logs: an argument for lidarflow-lcm-bridge --replay, repeatable "
                        "(e.g. --bridge-arg=--lidar-channel --bridge-arg=VELO)")
    p.add_argument("sources", nargs="+", metavar="SOURCE")
    a = p.parse_args(argv)
    if a.workers is not None and a.workers < 0:
        p.error("--workers %d: 0 or more" % a.workers)
    if a.threads_per_worker < 1:
        p.error("--threads-per-worker %d: at least 1" % a.threads_per_worker)
    for kv in a.option:
        if "=" not in kv or kv.startswith("="):
            p.error("--option %s: expected K=V" % kv)
    if a.stereo_channel != "LIDARFLOW_STEREO":
        a.bridge_arg = ["--stereo-channel", a.stereo_channel] + a.bridge_arg
    return a


def main(argv=None):
    a = parse(sys.argv[1:] if argv is None else argv)
    serial = a.serial or a.workers == 0
    workers = 0 if serial else (a.workers or 2)
    if a.threads_per_task:
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
                                   stereo_channel=a.stereo_channel, bridge_args=a.bridge_arg)
        if serial:
            rc, _ = runner.run(a.sources, settings, client=None)
            return rc
        from distributed import Client, LocalCluster
        progress_bar = sys.stderr.isatty()
        if a.scheduler:
            with Client(a.scheduler) as client:
                rc, _ = runner.run(a.sources, settings, client=client, progress_bar=progress_bar)
            return rc
        with LocalCluster(n_workers=workers, threads_per_worker=a.threads_per_worker, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            rc, _ = runner.run(a.sources, settings, client=client, progress_bar=progress_bar)
        return rc
    except (runner.SourceError, ValueError) as e:
        print("lidarflow_dask: %s" % e, file=sys.stderr)
        return 2
    except (chunks.ToolNotFound, runner.ClusterError) as e:
        print("lidarflow_dask: %s" % e, file=sys.stderr)
        return 1
    except OSError as e:
        print("lidarflow_dask: %s" % e, file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
