# SPDX-License-Identifier: MIT
"""The library's messages (lf_set_log_callback) go to the standard `logging` module's "lidarflow"
logger: LiDAR points dropped, fallbacks, frames the stream could not reuse, each naming the
estimator handle and frame. The logger has a NullHandler, so nothing shows until the program
configures logging, e.g. logging.basicConfig(level=logging.INFO). The library's levels are
logging's (DEBUG 10, INFO 20, WARNING 30, ERROR 40).

The callback is process-wide: importing lidarflow replaces a callback another user of the
library installed in this process.
"""
import atexit
import logging
import threading

from ._lib import LOG_FN, OK, lib

logger = logging.getLogger("lidarflow")
logger.addHandler(logging.NullHandler())


_state = threading.local()


def in_callback():
    """True on a thread that is running a handler of the library's messages."""
    return getattr(_state, "depth", 0) > 0


@LOG_FN
def _forward(level, message, user):
    # Runs on the thread of the library call (or on a frame worker of the estimator, with
    # frames in flight), GIL taken by ctypes; nothing may raise into C.
    _state.depth = getattr(_state, "depth", 0) + 1
    try:
        if logger.isEnabledFor(level):
            logger.log(level, message.decode("utf-8", "replace"))
    except Exception:  # noqa: BLE001 - an exception cannot cross into the library
        pass
    finally:
        _state.depth -= 1


def _install():
    if lib.lf_set_log_callback(_forward, logging.DEBUG, None) != OK:
        raise ImportError("lidarflow: lf_set_log_callback failed: %s" % lib.lf_last_error(None).decode())
    # Silence the library before the interpreter (and _forward) goes away.
    atexit.register(lib.lf_set_log_callback, LOG_FN(), logging.DEBUG, None)  # LOG_FN(): NULL


_install()
