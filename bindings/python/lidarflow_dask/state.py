# SPDX-License-Identifier: MIT
"""What a run keeps under OUT/.lidarflow_dask/ for the next one, and the lock on OUT.

    OUT/.lidarflow_dask/.lock                    held (flock) by the one run into OUT
    OUT/.lidarflow_dask/<safe name>/settings.json   what the source's results were computed with
    OUT/.lidarflow_dask/<safe name>/AAAAAAAAAA-BBBBBBBBBB.done   a complete chunk (marker)
    OUT/.lidarflow_dask/<safe name>/AAAAAAAAAA-BBBBBBBBBB.log    an LCM chunk's results

Every file here is read bounded (regular files of at most MAX_STATE_BYTES) and validated; an
error names the file. A run deletes only files of these names (and its own temporaries).
"""
import errno
import fcntl
import json
import math
import os
import re
import socket
import stat
import time
import uuid

STATE_DIR = ".lidarflow_dask"
LOCK_NAME = ".lock"  # safe names never start with a dot
MAX_STATE_BYTES = 64 * 1024
CHUNK_FILE = re.compile(r"^\d{10}-\d{10}\.(done|log)$")
# write_atomically's temporaries of the files above and of settings.json.
TEMPORARY = re.compile(r"^(\d{10}-\d{10}\.(done|log)|settings\.json)\.tmp\.")
_SAFE = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.")


class StateError(ValueError):
    """A state file that is not what this package writes (the message names it)."""


class Busy(RuntimeError):
    """Another run holds OUT's lock."""


def safe_name(name):
    """A source name as one plain path component: bytes outside [A-Za-z0-9_.-] and a leading dot
    percent-encoded, so '..', '.' or a name with '/' never leaves the state folder."""
    out = []
    for i, c in enumerate(name):
        if c in _SAFE and not (i == 0 and c == "."):
            out.append(c)
        else:
            out.extend("%%%02X" % b for b in c.encode("utf-8", "surrogateescape"))
    return "".join(out)


def state_root(out):
    return os.path.join(out, STATE_DIR)


def state_dir(out, name):
    return os.path.join(state_root(out), safe_name(name))


class Lock:
    """flock on OUT/.lidarflow_dask/.lock for the whole run; Busy names the holder."""

    def __init__(self, out):
        self.out, self.path = out, os.path.join(state_root(out), LOCK_NAME)
        self.fd = None

    def __enter__(self):
        os.makedirs(os.path.dirname(self.path), exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            holder = os.pread(fd, 512, 0).decode("utf-8", "replace").strip() or "another process"
            os.close(fd)
            if e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise Busy("%s is in use by another lidarflow_dask run (%s; lock %s)"
                           % (self.out, holder, self.path)) from None
            raise
        os.ftruncate(fd, 0)
        os.pwrite(fd, ("pid %d on %s since %s\n" % (os.getpid(), socket.gethostname(),
                                                     time.strftime("%Y-%m-%d %H:%M:%S"))).encode(), 0)
        self.fd = fd
        return self

    def __exit__(self, *exc):
        os.close(self.fd)  # releases the lock; the file stays (removing it would race a waiter)
        self.fd = None


def read_json(path, what):
    """The JSON value of a small regular file; StateError naming the file otherwise. None when
    the file does not exist."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        return None
    except OSError as e:
        raise StateError("%s: cannot read %s: %s" % (path, what, e.strerror or e)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise StateError("%s: %s is not a regular file" % (path, what))
        if st.st_size > MAX_STATE_BYTES:
            raise StateError("%s: %s of %d bytes (at most %d)" % (path, what, st.st_size, MAX_STATE_BYTES))
        data = os.read(fd, MAX_STATE_BYTES + 1)
    except OSError as e:
        raise StateError("%s: cannot read %s: %s" % (path, what, e.strerror or e)) from None
    finally:
        os.close(fd)
    if len(data) > MAX_STATE_BYTES:
        raise StateError("%s: %s over %d bytes" % (path, what, MAX_STATE_BYTES))
    try:
        return json.loads(data.decode("utf-8"), parse_constant=_no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise StateError("%s: %s is not valid JSON: %s" % (path, what, e)) from None


def _no_constant(name):
    raise ValueError("%s is not a number" % name)


def check_marker(path, first, last):
    """The pairs a chunk marker vouches for (last - first); StateError naming the file when it is
    not a marker of frames first..last, None when there is none."""
    m = read_json(path, "chunk marker")
    if m is None:
        return None
    if not isinstance(m, dict) or set(m) != {"host", "pairs", "seconds", "frames"}:
        raise StateError("%s: not a chunk marker (expected host, pairs, seconds, frames)" % path)
    pairs, seconds = m["pairs"], m["seconds"]
    if not isinstance(m["host"], str) or len(m["host"]) > 255:
        raise StateError("%s: chunk marker: bad host" % path)
    if type(pairs) is not int or pairs != last - first:
        raise StateError("%s: chunk marker: pairs %r, frames %d:%d hold %d" % (path, pairs, first, last, last - first))
    if type(seconds) not in (int, float) or not math.isfinite(seconds) or seconds < 0:
        raise StateError("%s: chunk marker: bad seconds %r" % (path, seconds))
    if m["frames"] != [first, last]:
        raise StateError("%s: chunk marker: frames %r, expected [%d, %d]" % (path, m["frames"], first, last))
    return pairs


def marker(host, pairs, seconds, first, last):
    return (json.dumps({"host": host, "pairs": pairs, "seconds": seconds, "frames": [first, last]}) + "\n").encode()


def check_settings(path, keys):
    """The settings recorded in `path` (a dict of exactly `keys`, JSON values), None when absent;
    StateError naming the file otherwise."""
    s = read_json(path, "settings file")
    if s is None:
        return None
    if not isinstance(s, dict) or set(s) != set(keys):
        raise StateError("%s: not a settings file of this version (expected the keys %s)" % (path, ", ".join(sorted(keys))))
    return s


def own_files(d, force):
    """Files of folder d a run may delete: temporaries left by attempts that died, and with force
    the chunk markers and chunk logs."""
    try:
        names = os.listdir(d)
    except FileNotFoundError:
        return []
    found = [os.path.join(d, n) for n in names if TEMPORARY.match(n) or (force and CHUNK_FILE.match(n))]
    return [p for p in found if not os.path.isdir(p) or os.path.islink(p)]  # a folder is not one of them


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
