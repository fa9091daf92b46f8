# SPDX-License-Identifier: MIT
"""A drive's rig given to the run, as `lidarflow sequence` takes it (docs/CALIBRATION.md): the
files checked here, once, and passed to every drive chunk under absolute paths (a worker may
run in another folder). What the files say is checked by the CLI where the chunks run."""
import hashlib
import os

NUMBERS = ("fx", "fy", "cx", "cy", "baseline")  # a rectified rig by numbers, instead of --calib


def _file(option, path):
    if not path:
        raise ValueError("%s: a file must be named (got '')" % option)
    full = os.path.abspath(path)
    if not os.path.isfile(full):
        raise ValueError("%s %s: %s (%s)" % (option, path, "not a file" if os.path.exists(full) else "no such file",
                                             full))
    return full


def calib_files(spec):
    """The files of --calib FILE[,FILE] as sequence reads it: the whole text when it names a
    file, else LEFT,RIGHT."""
    if "," not in spec or os.path.exists(spec):
        return [spec]
    parts = spec.split(",")
    if len(parts) != 2 or not all(parts):
        raise ValueError("--calib %s: expected FILE or LEFT,RIGHT (two camera_info files)" % spec)
    return parts


def _digest(option, path):
    try:
        with open(path, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()
    except OSError as e:
        raise ValueError("%s %s: %s" % (option, path, e.strerror or e)) from None


def rig_args(calib=None, calib_velo=None, camera=None, strict=False):
    """(sequence's rig arguments, absolute paths; {file: sha256 of its content}): what the
    results depend on is the files' content, not their names. camera: {fx, cx, cy, baseline[, fy]}.
    ValueError for a file that is not there, a number that is not one, an unknown key."""
    args, files = [], []
    if calib is not None:
        paths = [_file("--calib", p) for p in calib_files(calib)]
        args += ["--calib", ",".join(paths)]
        files += [("--calib", p) for p in paths]
    if calib_velo is not None:
        path = _file("--calib-velo", calib_velo)
        args += ["--calib-velo", path]
        files.append(("--calib-velo", path))
    camera = dict(camera or {})
    unknown = sorted(set(camera) - set(NUMBERS))
    if unknown:
        raise ValueError("camera: unknown key(s) %s (known: %s)" % (", ".join(unknown), ", ".join(NUMBERS)))
    for key in NUMBERS:
        if camera.get(key) is not None:
            try:
                args += ["--" + key, repr(float(camera[key]))]  # repr: the same double again
            except (TypeError, ValueError):
                raise ValueError("--%s %r: not a number" % (key, camera[key])) from None
    if strict:
        args.append("--strict")
    return args, {p: _digest(option, p) for option, p in files}
