# SPDX-License-Identifier: MIT
"""Where the project's executables are, on the host that asks."""
import os
import socket

CLI, BRIDGE = "lidarflow", "lidarflow-lcm-bridge"


class ToolNotFound(RuntimeError):
    """The lidarflow CLI or the bridge is not installed where it is looked for."""


def _executable(path):
    return os.path.isfile(path) and os.access(path, os.X_OK)


def find_tool(name, bin_dir=None):
    """Path of the executable `name`: in bin_dir (else $LIDARFLOW_BIN_DIR) when given, else next
    to this package's installation (PREFIX/bin for PREFIX/lib/python3/dist-packages), else on
    the PATH. Raises ToolNotFound saying where it looked."""
    bin_dir = bin_dir or os.environ.get("LIDARFLOW_BIN_DIR")
    if bin_dir:
        # A build tree keeps the CLI and the bridge in folders of their own.
        for sub in ("", "tools/lidarflow", "bridge"):
            path = os.path.join(bin_dir, sub, name)
            if _executable(path):
                return path
        raise ToolNotFound("%s not found in %s (LIDARFLOW_BIN_DIR / --bin-dir) on %s"
                           % (name, bin_dir, socket.gethostname()))
    here = os.path.dirname(os.path.abspath(__file__))
    prefix = os.path.normpath(os.path.join(here, "..", "..", "..", ".."))
    looked = [os.path.join(prefix, "bin")]
    path = os.path.join(looked[0], name)
    if _executable(path):
        return path
    for d in os.environ.get("PATH", "").split(os.pathsep):
        path = os.path.join(d or ".", name)
        if _executable(path):
            return path
    raise ToolNotFound("%s not found in %s or on the PATH on %s (install lidarflow-tools, or set "
                       "LIDARFLOW_BIN_DIR / --bin-dir to a build tree)" % (name, looked[0], socket.gethostname()))


def check_tools(kinds, bin_dir=None):
    """'' when the executables for the source kinds (and the CLI, which checks the options) are
    found on this host, else why not."""
    try:
        if "lcm" in kinds:
            find_tool(BRIDGE, bin_dir)
        find_tool(CLI, bin_dir)
    except ToolNotFound as e:
        return str(e)
    return ""
