# SPDX-License-Identifier: MIT
"""lidarflow_dask and its Dask cluster (CTest: python_dask).

  * a local cluster listens on loopback only and keeps its scratch space under TMPDIR;
  * a chunk that hangs is killed at --chunk-timeout and reported; the run goes on;
  * a scheduler that dies mid-run is reported as such (exit 1), without tracebacks.
"""
import json
import os
import signal
import subprocess
import time
import unittest

from dask_fixture import BIN, PY, FixtureCase, cli, cmdline, fake_bin, processes, serial_args

if BIN:
    from lidarflow_dask import chunks
    from lidarflow_dask.cluster import local_cluster

HANG = "exec sleep 637"  # a chunk that never ends (its number tells its processes apart)


def listening(pids):
    """Local addresses (hex, as /proc/net/tcp* writes them) of the listening TCP sockets of pids."""
    inodes = set()
    for pid in pids:
        try:
            for fd in os.listdir("/proc/%d/fd" % pid):
                target = os.readlink("/proc/%d/fd/%s" % (pid, fd))
                if target.startswith("socket:["):
                    inodes.add(target[8:-1])
        except OSError:
            continue
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as f:
            for line in f.readlines()[1:]:
                fields = line.split()
                if fields[3] == "0A" and fields[9] in inodes:  # LISTEN
                    found.append(fields[1].split(":")[0])
    return found


def descendants(pid):
    out, unvisited = [], [pid]
    table = processes()
    while unvisited:
        p = unvisited.pop()
        kids = [c for c, parent, _ in table if parent == p]
        out += kids
        unvisited += kids
    return out


def hung(pids_before=()):
    return [p for p, _, comm in processes() if comm == "sleep" and "637" in cmdline(p) and p not in pids_before]


class Cluster(FixtureCase):
    def test_local_cluster_on_loopback_scratch_under_tmpdir(self):
        tmp = self.f.folder("tmpdir")
        old = os.environ.get("TMPDIR")
        os.environ["TMPDIR"] = tmp
        import tempfile
        tempfile.tempdir = None  # read TMPDIR again
        try:
            with local_cluster(2, 1) as client:
                dirs = client.run(lambda dask_worker: dask_worker.local_directory)
                addresses = listening([os.getpid()] + descendants(os.getpid()))
        finally:
            if old is None:
                del os.environ["TMPDIR"]
            else:
                os.environ["TMPDIR"] = old
            tempfile.tempdir = None
        self.assertEqual(len(dirs), 2)
        for d in dirs.values():
            self.assertTrue(d.startswith(tmp + os.sep), d)
        self.assertGreaterEqual(len(addresses), 3)  # the scheduler, its HTTP server, the workers
        loopback = ("0100007F", "00000000000000000000000001000000")  # 127.0.0.1, ::1
        self.assertEqual([a for a in addresses if a not in loopback], [])
        self.assertEqual(os.listdir(tmp), [])  # the scratch space is gone

    def test_hung_chunk_killed_at_timeout(self):
        before = hung()
        out = self.f.folder("hang")
        bin_dir = fake_bin(self.f.folder("hangbin"), HANG)
        t0 = time.monotonic()
        p = cli(*[a if a != BIN else bin_dir for a in serial_args(out, self.f.drive)] + ["--chunk-timeout", "1"],
                timeout=120)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertEqual(p.stderr.count("timed out after 1 s (--chunk-timeout), killed"), 3, p.stderr)
        self.assertLess(time.monotonic() - t0, 60)
        self.assertEqual(hung(before), [])
        self.assertEqual(chunks.default_timeout(19), 120 + 60 * 19)

    def test_scheduler_death_reported(self):
        t = self.f.folder("sched")
        bin_dir = fake_bin(os.path.join(t, "bin"), HANG)
        sfile = os.path.join(t, "scheduler.json")
        env = dict(os.environ, PYTHONPATH=os.environ.get("PYTHONPATH", ""))
        before = hung()
        procs = []
        try:
            procs.append(subprocess.Popen([PY, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                                           "0", "--dashboard-address", "127.0.0.1:0", "--scheduler-file", sfile],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
            deadline = time.monotonic() + 60
            while not os.path.exists(sfile) and time.monotonic() < deadline:
                time.sleep(0.1)
            time.sleep(0.2)
            with open(sfile) as f:
                address = json.load(f)["address"]
            procs.append(subprocess.Popen([PY, "-m", "distributed.cli.dask_worker", address, "--host", "127.0.0.1",
                                           "--nthreads", "1", "--nworkers", "1", "--dashboard-address", "127.0.0.1:0",
                                           "--local-directory", t], stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, env=env))
            run = subprocess.Popen([PY, "-m", "lidarflow_dask", "--scheduler", address, "--bin-dir", bin_dir, "--out",
                                    os.path.join(t, "out"), "--chunk", "4", self.f.drive],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 120
            while not hung(before) and time.monotonic() < deadline and run.poll() is None:
                time.sleep(0.1)
            self.assertTrue(hung(before), "no chunk started")
            procs[0].kill()
            _, err = run.communicate(timeout=120)
        finally:
            for p in reversed(procs):
                for pid in descendants(p.pid):
                    try:
                        os.kill(pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
                p.kill()
                p.wait()
            for pid in hung(before):
                os.kill(pid, signal.SIGKILL)
        self.assertEqual(run.returncode, 1, err)
        self.assertIn("lost the Dask scheduler %s mid-run: 3 chunk(s) not finished" % address, err)
        self.assertNotIn("Traceback", err)
        self.assertNotIn("cancelled", err)


if __name__ == "__main__":
    unittest.main()
