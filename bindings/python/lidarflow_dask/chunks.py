# SPDX-License-Identifier: MIT
"""One chunk of one source, computed by the project's own executables in a subprocess.

This is what a Dask task runs (on any worker) and what the serial run calls in order. A chunk
is a dict (plain data, so it pickles to any worker):

    kind      "drive" or "lcm"
    source    the drive folder or the LCM log (the same path on every host: shared storage)
    name      the source's name in the output folder
    first, last   frames first..last, both included, all present: the pairs (first, first+1) .. (last-1, last)
    out       the output folder (shared storage)
    preset, options, formats, threads, force, bin_dir, stereo_channel, bridge_args, timeout   see runner.Settings
    rig_args  a drive's rig options for lidarflow sequence, paths absolute (Settings.rig_args)
    warm_up   frames before `first` that feed the stream's priors, not written (0 for a source's first chunk)

run_chunk() never raises for bad data or a missing tool: it returns a result dict (rc, pairs,
seconds, host, message) that the caller reports. It is safe to run twice, also concurrently:
every file it leaves is complete, written under a name of its own and renamed into place.
"""
import ctypes
import os
import signal
import socket
import subprocess
import tempfile
import time
import uuid

from . import results, state
from .tools import BRIDGE, CLI, ToolNotFound, find_tool

_PR_SET_PDEATHSIG = 1
TIMED_OUT = -1000  # rc of a chunk killed for running past its timeout


def default_timeout(pairs):
    """Seconds a chunk of `pairs` pairs may run: start-up plus a minute a pair (a KITTI pair with
    the paper preset on one loaded core takes seconds, not minutes)."""
    return 120 + 60 * pairs


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


def marker_path(chunk):
    return os.path.join(state.state_dir(chunk["out"], chunk["name"]), chunk_key(chunk) + ".done")


def chunk_log_path(chunk):
    return os.path.join(state.state_dir(chunk["out"], chunk["name"]), chunk_key(chunk) + ".log")


def describe(chunk):
    return "%s frames %d:%d" % (chunk["source"], chunk["first"], chunk["last"])


def drive_out(chunk):
    return os.path.join(chunk["out"], chunk["name"])


def option_args(options):
    out = []
    for kv in options:
        out += ["--option", kv]
    return out


def warm_up_args(chunk):
    """The chunk's --warm-up, which lidarflow sequence and the bridge's --replay take alike."""
    return ["--warm-up", str(chunk["warm_up"])] if chunk.get("warm_up") else []


def command(chunk, tool, tmp_log=None):
    """The chunk's command line."""
    frames = "%d:%d" % (chunk["first"], chunk["last"])
    if chunk["kind"] == "drive":
        cmd = [tool, "sequence", "--drive", chunk["source"], "--frames", frames, "--out", drive_out(chunk),
               "--threads", str(chunk["threads"]), "--format", ",".join(chunk["formats"]), "--quiet"]
        if chunk["preset"]:
            cmd += ["--preset", chunk["preset"]]
        if not chunk["force"]:
            cmd.append("--skip-existing")
        return cmd + warm_up_args(chunk) + option_args(chunk["options"]) + list(chunk["rig_args"])
    cmd = [tool, "--replay", chunk["source"], "--out", tmp_log, "--frames", frames] + warm_up_args(chunk) + \
        ["--option", "threads=%d" % chunk["threads"]]
    if chunk["preset"]:
        cmd += ["--option", "preset=" + chunk["preset"]]
    return cmd + option_args(chunk["options"]) + list(chunk["bridge_args"])


def execute(cmd, timeout):
    """(rc, output) of cmd in a session of its own, the whole session killed past `timeout` s
    (rc TIMED_OUT) or when this call is interrupted."""
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                         preexec_fn=_die_with_parent(os.getpid()), start_new_session=True, text=True,
                         errors="replace")
    try:
        out, _ = p.communicate(timeout=timeout)
        return p.returncode, out
    except subprocess.TimeoutExpired:
        return TIMED_OUT, ""
    finally:
        if p.returncode is None:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.communicate()


def _tail(text, lines=8):
    return "\n".join(text.strip().splitlines()[-lines:])


def check_settings(preset, options, formats, threads, bin_dir=None, rig_args=()):
    """'' when the CLI accepts the preset, options, formats, thread count and rig, else its
    message. `lidarflow sequence` checks them before it reads the drive, so a drive that is not
    there tells them apart: exit 2 is theirs, and so is exit 1 before the drive's error when a
    rig is given (its files are read first)."""
    tool = find_tool(CLI, bin_dir)
    with tempfile.TemporaryDirectory(prefix="lidarflow_dask-check-") as tmp:
        cmd = [tool, "sequence", "--drive", os.path.join(tmp, "none"), "--out", os.path.join(tmp, "out"),
               "--threads", str(threads), "--format", ",".join(formats)] + option_args(options) + list(rig_args)
        if preset:
            cmd += ["--preset", preset]
        rc, out = execute(cmd, 60)
    if rc == 1 and "is not a folder" in out:
        return ""
    if rc == 2 or (rc == 1 and rig_args):
        return _tail(out, 3).replace("lidarflow sequence: error: ", "")
    return "cannot check the options with %s: %s" % (tool, "timed out" if rc == TIMED_OUT else _tail(out, 3))


def run_chunk(chunk):
    """Computes one chunk; returns {rc, pairs, seconds, host, message, chunk}. rc: the tool's exit
    status (0 every pair computed; 3 some frames bad, the others' results kept; else an error),
    -1 when the tool is missing, could not start or left fewer results than the chunk's pairs,
    TIMED_OUT past the chunk's timeout. On rc 0 a marker records the chunk as complete, so a
    rerun skips it (while its results are there)."""
    host = socket.gethostname()
    expected = chunk["last"] - chunk["first"]
    result = {"chunk": chunk, "host": host, "rc": -1, "pairs": 0, "seconds": 0.0, "message": ""}
    t0 = time.monotonic()
    try:
        tool = find_tool(CLI if chunk["kind"] == "drive" else BRIDGE, chunk["bin_dir"])
    except ToolNotFound as e:
        result["message"] = str(e)
        return result
    tmp_log = None
    if chunk["kind"] == "lcm":
        # The bridge writes as it goes: a name of this attempt's own, renamed when it ends.
        tmp_log = "%s.tmp.%s.%d.%s" % (chunk_log_path(chunk), host, os.getpid(), uuid.uuid4().hex[:8])
    timeout = chunk["timeout"] or None
    try:
        os.makedirs(state.state_dir(chunk["out"], chunk["name"]), exist_ok=True)
        rc, out = execute(command(chunk, tool, tmp_log), timeout)
        result["seconds"] = time.monotonic() - t0
        result["rc"] = rc
        result["pairs"] = count_results(chunk, rc, tmp_log)
        if rc == 0 and result["pairs"] != expected:
            # A source that shrank since it was planned, or results deleted meanwhile: not complete.
            result["rc"] = -1
            result["message"] = "exit 0 but %d of the %d pairs' results (has the source changed since the run " \
                                "started?): %s" % (result["pairs"], expected, _tail(out) or "(no output)")
        elif rc == 0:
            if tmp_log:
                os.replace(tmp_log, chunk_log_path(chunk))
            state.write_atomically(marker_path(chunk), state.marker(host, expected, result["seconds"],
                                                                    chunk["first"], chunk["last"]))
        elif rc == TIMED_OUT:
            result["message"] = "timed out after %g s (--chunk-timeout), killed" % timeout
        else:
            why = "killed by signal %d" % -rc if rc < 0 else "exit %d" % rc
            result["message"] = "%s: %s" % (why, _tail(out) or "(no output)")
    except OSError as e:  # the tool could not start, or OUT refuses a file (a folder in a marker's place)
        result["message"] = ("cannot keep the results: %s" if result["seconds"] else "cannot run " + tool + ": %s") % e
        result["rc"] = -1
    finally:
        if tmp_log and os.path.exists(tmp_log):
            os.unlink(tmp_log)
    return result


def count_results(chunk, rc, tmp_log):
    """Pairs of the chunk whose results the tool left."""
    if chunk["kind"] == "lcm":
        return (results.count_flows(tmp_log) or 0) if rc in (0, 3) else 0
    return results.drive_pairs_complete(drive_out(chunk), chunk["first"], chunk["last"], chunk["formats"])
