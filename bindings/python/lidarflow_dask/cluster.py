# SPDX-License-Identifier: MIT
"""The Dask side: a local cluster on loopback, the workers' checks, chunks as tasks."""
import contextlib
import shutil
import tempfile

from . import chunks as ch
from .tools import check_tools

LOOPBACK = "127.0.0.1"


class ClusterError(RuntimeError):
    """No worker, workers that cannot run the chunks (the executables or lidarflow_dask missing),
    or the scheduler lost mid-run."""


@contextlib.contextmanager
def local_cluster(workers, threads_per_worker):
    """A Client of a local cluster of `workers` processes that listens on loopback only (the
    scheduler, the workers, their HTTP servers on free ports, no dashboard), with its scratch
    space in a folder of its own under TMPDIR, removed afterwards."""
    from distributed import Client, LocalCluster
    scratch = tempfile.mkdtemp(prefix="lidarflow_dask-")
    try:
        with LocalCluster(n_workers=workers, threads_per_worker=threads_per_worker, processes=True, host=LOOPBACK,
                          dashboard_address=None, worker_dashboard_address=LOOPBACK + ":0", local_directory=scratch,
                          scheduler_kwargs={"dashboard": False, "dashboard_address": LOOPBACK + ":0"}) as c, \
                Client(c) as client:
            yield client
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def check_workers(client, kinds, bin_dir):
    """Raises ClusterError unless a worker has joined and every worker finds the executables."""
    # Workers started just before may not have joined yet: the check needs at least one.
    try:
        client.wait_for_workers(1, timeout=120)
    except TimeoutError:
        raise ClusterError("no Dask worker joined the scheduler within 120 s") from None
    answers = client.run(check_tools, sorted(kinds), bin_dir, on_error="return")
    bad = {}
    for w, why in answers.items():
        if isinstance(why, BaseException):  # e.g. lidarflow_dask not importable there
            bad[w] = "%s: %s (install python3-lidarflow-dask on every worker host)" % (type(why).__name__, why)
        elif why:
            bad[w] = why
    if bad:
        raise ClusterError("; ".join("worker %s: %s" % kv for kv in sorted(bad.items())))


def on_one_worker(client, function, *args):
    """function(*args) on some worker, its result here."""
    return client.submit(function, *args, pure=False).result()


def scheduler_lost(client):
    """True when the client no longer reaches its scheduler."""
    if client.status != "running":
        return True
    try:
        client.sync(client.scheduler.identity, callback_timeout=10)
        return False
    except Exception:  # any failure to answer: the scheduler is gone
        return True


def run_dask(pending, report, client, progress_bar):
    from distributed import as_completed, progress
    # pure=False: a rerun after a failure is a new task, not the cached failed one.
    futures = client.map(ch.run_chunk, pending, pure=False, key=["lidarflow-%s-%s" % (c["name"], ch.chunk_key(c))
                                                              for c in pending])
    chunk_of = {f.key: c for f, c in zip(futures, pending)}
    if progress_bar:
        progress(futures)
        print(file=report.stream)
    unfinished = []
    for f in as_completed(futures):
        if f.status == "finished":
            report.add(f.result())
        elif f.status == "error":
            # e.g. KilledWorker: the chunk took down workers more often than Dask allows.
            report.lost(chunk_of[f.key], "%s: %s" % (type(f.exception()).__name__, f.exception()))
        else:
            unfinished.append(chunk_of[f.key])
    if unfinished:
        if scheduler_lost(client):
            raise ClusterError("lost the Dask scheduler %s mid-run: %d chunk(s) not finished (the finished ones "
                               "are kept; rerun the command to compute the rest)"
                               % (client.scheduler.address, len(unfinished)))
        for c in unfinished:
            report.lost(c, "its task was cancelled")
