# SPDX-License-Identifier: MIT
"""One chunk of one source, computed by the project's own executables in a subprocess.

This is what a Dask task runs (on any worker) and what the serial run calls in order. A chunk
is a dict (plain data, so it pickles to any worker):

    kind      "drive" or "lcm"
    source    the drive folder or the LCM log (the same path on every host: shared storage)
    name      the source's name in the output folder
    first, last   frames first..last, both included: the pairs (first, first+1) .. (last-1, last)
    out       the output folder (shared storage)
    preset, options, threads, force, bin_dir, stereo_channel, bridge_args   see runner.Settings

run_chunk() never raises for bad data or a missing tool: it returns a result dict (rc, pairs,
seconds, host, message) that the caller reports. It is safe to run twice, also concurrently:
every file it leaves is complete, written under a name of its own and renamed into place.
"""
import ctypes
import json
import os
import signal
import socket
import subprocess
import time
import uuid

from lidarflow_lcm.eventlog import LogReader

CLI, BRIDGE = "lidarflow", "lidarflow-lcm-bridge"
FLOW_CHANNEL = "LIDARFLOW_FLOW"
EGO_CHANNEL = "LIDARFLOW_EGO_MOTION"  # the ego_motion_t that comes with each result
STATE_DIR = ".lidarflow_dask"  # under the output folder: chunk markers and chunk logs
_PR_SET_PDEATHSIG = 1


class ToolNotFound(RuntimeError):
    """The lidarflow CLI or the bridge is not installed where it is looked for."""


def find_tool(name, bin_dir=None):
    """Path of the executable `name`: in bin_dir (else $LIDARFLOW_BIN_DIR) when given, else next
    to this package's installation (PREFIX/bin for PREFIX/lib/python3/dist-packages), else on
    the PATH. Raises ToolNotFound saying where it looked."""
    bin_dir = bin_dir or os.environ.get("LIDARFLOW_BIN_DIR")
    if bin_dir:
        # A build tree keeps the CLI and the bridge in folders of their own.
        for sub in ("", "tools/lidarflow", "bridge"):
            path = os.path.join(bin_dir, sub, name)
            if os.path.isfile(path) and os.access(path, os.X_OK):
                return path
        raise ToolNotFound("%s not found in %s (LIDARFLOW_BIN_DIR / --bin-dir) on %s"
                           % (name, bin_dir, socket.gethostname()))
    here = os.path.dirname(os.path.abspath(__file__))
    prefix = os.path.normpath(os.path.join(here, "..", "..", "..", ".."))
    looked = [os.path.join(prefix, "bin")]
    path = os.path.join(looked[0], name)
    if os.path.isfile(path) and os.access(path, os.X_OK):
        return path
    for d in os.environ.get("PATH", "").split(os.pathsep):
        path = os.path.join(d or ".", name)
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    raise ToolNotFound("%s not found in %s or on the PATH on %s (install lidarflow-tools, or set "
                       "LIDARFLOW_BIN_DIR / --bin-dir to a build tree)" % (name, looked[0], socket.gethostname()))


def check_tools(kinds, bin_dir=None):
    """'' when the executables for the source kinds are found on this host, else why not."""
    try:
        for kind in sorted(kinds):
            find_tool(CLI if kind == "drive" else BRIDGE, bin_dir)
    except ToolNotFound as e:
        return str(e)
    return ""


try:
    _prctl = ctypes.CDLL(None, use_errno=True).prctl
except (OSError, AttributeError):  # not Linux: no parent-death signal
    _prctl = None


def _die_with_parent(parent_pid):
    """preexec_fn: the chunk process is killed when the thread that started it (the Dask worker's)
    dies, e.g. a worker killed mid-chunk, so no orphan computes on. Looked up before the fork:
    nothing is loaded in the child."""
    def set_signal():
        if _prctl is not None:
            _prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        if os.getppid() != parent_pid:  # the parent died before the signal was armed
            os._exit(1)
    return set_signal


def chunk_key(chunk):
    return "%010d-%010d" % (chunk["first"], chunk["last"])


def state_dir(out, name):
    return os.path.join(out, STATE_DIR, name)


def marker_path(chunk):
    return os.path.join(state_dir(chunk["out"], chunk["name"]), chunk_key(chunk) + ".done")


def chunk_log_path(chunk):
    return os.path.join(state_dir(chunk["out"], chunk["name"]), chunk_key(chunk) + ".log")


def write_atomically(path, data):
    """Writes `data` (bytes, or a function that writes to the binary file it is given) to a
    unique temporary name beside `path`, syncs, renames it over `path`."""
    tmp = "%s.tmp.%s.%d.%s" % (path, socket.gethostname(), os.getpid(), uuid.uuid4().hex[:8])
    try:
        with open(tmp, "wb") as f:
            if callable(data):
                data(f)
            else:
                f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def count_flows(log, channel=FLOW_CHANNEL):
    """Scene-flow results in a result log (headers only)."""
    with LogReader(log, channels=channel, data=False) as r:
        return sum(1 for _ in r)


def drive_pairs_written(out_dir, first, last):
    """t0 frames in first..last-1 that have a flow file in out_dir/flow/ (any format)."""
    try:
        names = os.listdir(os.path.join(out_dir, "flow"))
    except FileNotFoundError:
        return 0
    done = set()
    for n in names:
        stem = n.split(".", 1)[0]
        if len(stem) == 10 and stem.isdigit() and first <= int(stem) < last:
            done.add(int(stem))
    return len(done)


def command(chunk, tool, tmp_log=None):
    """The chunk's command line."""
    opts = []
    for kv in chunk["options"]:
        opts += ["--option", kv]
    frames = "%d:%d" % (chunk["first"], chunk["last"])
    if chunk["kind"] == "drive":
        cmd = [tool, "sequence", "--drive", chunk["source"], "--frames", frames,
               "--out", os.path.join(chunk["out"], chunk["name"]), "--threads", str(chunk["threads"]), "--quiet"]
        if chunk["preset"]:
            cmd += ["--preset", chunk["preset"]]
        if not chunk["force"]:
            cmd.append("--skip-existing")
        return cmd + opts
    cmd = [tool, "--replay", chunk["source"], "--out", tmp_log, "--frames", frames,
           "--option", "threads=%d" % chunk["threads"]]
    if chunk["preset"]:
        cmd += ["--option", "preset=" + chunk["preset"]]
    return cmd + opts + list(chunk["bridge_args"])


def _tail(text, lines=8):
    return "\n".join(text.strip().splitlines()[-lines:])


def run_chunk(chunk):
    """Computes one chunk; returns {rc, pairs, seconds, host, message, chunk}. rc: the tool's exit
    status (0 every pair computed; 3 some frames bad, the others' results kept; else an error),
    or -1 when the tool is missing or could not start. On rc 0 a marker records the chunk as
    complete, so a rerun skips it."""
    host = socket.gethostname()
    result = {"chunk": chunk, "host": host, "rc": -1, "pairs": 0, "seconds": 0.0, "message": ""}
    t0 = time.monotonic()
    try:
        tool = find_tool(CLI if chunk["kind"] == "drive" else BRIDGE, chunk["bin_dir"])
    except ToolNotFound as e:
        result["message"] = str(e)
        return result
    os.makedirs(state_dir(chunk["out"], chunk["name"]), exist_ok=True)
    tmp_log = None
    if chunk["kind"] == "lcm":
        # The bridge writes as it goes: a name of this attempt's own, renamed when it ends.
        tmp_log = "%s.tmp.%s.%d.%s" % (chunk_log_path(chunk), host, os.getpid(), uuid.uuid4().hex[:8])
    cmd = command(chunk, tool, tmp_log)
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                           preexec_fn=_die_with_parent(os.getpid()), text=True, errors="replace")
    except OSError as e:
        result["message"] = "cannot run %s: %s" % (tool, e)
        return result
    finally:
        result["seconds"] = time.monotonic() - t0
    result["rc"] = p.returncode
    if chunk["kind"] == "lcm":
        try:
            if p.returncode in (0, 3) and os.path.exists(tmp_log):
                result["pairs"] = count_flows(tmp_log)
                os.replace(tmp_log, chunk_log_path(chunk))
        finally:
            if os.path.exists(tmp_log):
                os.unlink(tmp_log)
    else:
        result["pairs"] = drive_pairs_written(os.path.join(chunk["out"], chunk["name"]), chunk["first"], chunk["last"])
    if p.returncode == 0:
        marker = {k: result[k] for k in ("host", "pairs", "seconds")}
        marker["frames"] = [chunk["first"], chunk["last"]]
        write_atomically(marker_path(chunk), (json.dumps(marker) + "\n").encode())
    else:
        if p.returncode < 0:
            why = "killed by signal %d" % -p.returncode
        else:
            why = "exit %d" % p.returncode
        result["message"] = "%s: %s" % (why, _tail(p.stderr + p.stdout) or "(no output)")
    return result
