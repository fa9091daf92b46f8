#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Mutation fuzzer of lidarflow_lcm's decoders and log reader (standard library + the package).

    fuzz_lcm.py [--executions N] [--seconds S] [--seed K] [--findings DIR]

Each execution takes a valid encoding (one message of each type and flavour, or a small log of
them), mutates its bytes (bit flips, interesting integers over length fields, inserted,
deleted, repeated or spliced ranges, truncation) and feeds it to:
- decode() with check=True and check=False, and the numpy views of what decodes: the only
  exception allowed is MessageError; what decodes encodes back to exactly the same bytes, and
  so does its decoding again;
- LogReader (strict=False: LogWarning only; strict=True: LogFormatError only) and
  read_messages (MessageError too); the events read, written again by LogWriter, read back
  equal.
Any other exception or warning is a finding.
An input that takes more than --hang-seconds (default 10) is a hang; the process runs under an
address-space limit (--memory-mib, default 4096), so unbounded allocation is a MemoryError,
itself a finding. A finding is written to --findings (default: the current folder) as
fuzz-lcm-<sha1>.bin with its traceback, and ends the run with exit status 1. Exit 0: the
executions ran without a finding; the last line gives executions, rate and decode outcomes.
"""
import argparse
import hashlib
import io
import os
import random
import resource
import signal
import struct
import sys
import time
import traceback
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import lidarflow_lcm as ll  # noqa: E402
from lidarflow_lcm import arrays, eventlog  # noqa: E402

MAX_INPUT = 1 << 16  # mutated inputs stay small: executions, not sizes, find the bugs
INTERESTING = [0, 1, 2, 3, 4, 7, 8, 16, 63, 64, 127, 128, 255, 256, 0x7FFF, 0x8000, 0xFFFF, 0x7FFFFFFF,
               0x80000000, 0xFFFFFFFF, 0x7FFFFFFFFFFFFFFF, 0x8000000000000000, 0xFFFFFFFFFFFFFFFF]


class Hang(Exception):
    pass


def message_seeds():
    """Valid encodings of every type, in each of their flavours."""
    rng = np.random.default_rng(3)
    gray = [rng.integers(0, 256, (4, 6), dtype=np.uint8) for _ in range(2)]
    rgb = [rng.integers(0, 256, (3, 5, 3), dtype=np.uint8) for _ in range(2)]
    seeds = [
        arrays.stereo_message(gray[0], gray[1], utime=1000, sequence=1, frame_number=5),
        arrays.stereo_message(rgb[0], rgb[1], utime=2000, colour_order="bgr"),
        arrays.lidar_message(np.array([[1, 2, 3], [4.5, 5, 6]], np.float32), utime=10),
        arrays.lidar_message(np.array([[1, 2, 10]], np.float32), utime=11, frame="camera"),
        arrays.lidar_message(np.array([[0.5, -1, 8], [3, 2, 20]], np.float32), utime=12, frame="lidar",
                             lidar_to_camera=np.eye(4)),
        arrays.calibration_message(721.5, 721.5, 609.6, 172.9, 0.54, utime=7, width=1242, height=375),
        ll.status_t(utime=99, uptime_seconds=1.5, stereo_received=3, shard_index=1, shard_count=3,
                    instance_id=-12345, shard_results_ignored=2, latency_mean_ms=float("nan"), last_error="bad frame"),
        ll.status_t(),
        ll.ego_motion_t(utime=200, utime0=100, sequence=1, state=ll.ego_motion_t.STATE_OK, inliers=900, candidates=1000,
                        transform=[0.6, -0.8, 0, 0.1, 0.8, 0.6, 0, -0.2, 0, 0, 1, -0.9, 0, 0, 0, 1]),
        ll.ego_motion_t(utime=300, utime0=200, state=ll.ego_motion_t.STATE_NOT_RUN,
                        transform=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
    ]
    u = rng.normal(0, 3, (4, 6)).astype(np.float32)
    valid = rng.random((4, 6)) > 0.3
    for encoding, step in (("int16", 1), ("float32", 1), ("int16", 2)):
        seeds.append(arrays.scene_flow_message(u, -u, u + 10, u + 9, valid, utime=200, utime0=100, encoding=encoding,
                                               step=step))
    return [m.encode() for m in seeds]


def log_seeds(messages):
    """Small logs: a few events of the message seeds, and one with a foreign channel."""
    logs = []
    for k in range(3):
        buf = io.BytesIO()
        w = ll.LogWriter(buf)
        for i, data in enumerate(messages[k::3]):
            w.write(("LIDARFLOW_STEREO", "LIDARFLOW_FLOW", "OTHER")[i % 3], data, utime=1000 * i)
        logs.append(buf.getvalue())
    return logs


def mutate(data, rng, corpus):
    """One to four random byte-level mutations of `data`."""
    b = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(10)
        n = len(b)
        if op == 0 and n:  # flip a bit
            i = rng.randrange(n)
            b[i] ^= 1 << rng.randrange(8)
        elif op == 1 and n:  # a random byte
            b[rng.randrange(n)] = rng.randrange(256)
        elif op == 2 and n >= 4:  # an interesting int32 / int64 over a field (lengths, sizes)
            size = rng.choice((4, 8)) if n >= 8 else 4
            i = rng.randrange(n - size + 1)
            v = rng.choice(INTERESTING) + rng.choice((0, 0, 0, -1, 1))
            b[i:i + size] = (v % (1 << (8 * size))).to_bytes(size, "big")
        elif op == 3:  # insert random bytes
            i = rng.randint(0, n)
            b[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
        elif op == 4 and n:  # delete a range
            i = rng.randrange(n)
            del b[i:i + rng.randint(1, 32)]
        elif op == 5 and n:  # repeat a range
            i = rng.randrange(n)
            j = min(n, i + rng.randint(1, 64))
            b[j:j] = b[i:j]
        elif op == 6 and n:  # truncate
            del b[rng.randrange(n):]
        elif op == 7:  # splice with another seed
            other = rng.choice(corpus)
            i, j = rng.randint(0, n), rng.randint(0, len(other))
            b = b[:i] + other[j:j + rng.randint(1, 256)] + b[i:]
        elif op == 8 and n:  # overwrite with another seed's bytes at the same place
            other = rng.choice(corpus)
            i = rng.randrange(n)
            b[i:i + 16] = other[i:i + 16]
        elif op == 9 and n >= 8:  # another type's fingerprint
            b[0:8] = rng.choice(ll.TYPES)._PACKED_FINGERPRINT
    return bytes(b[:MAX_INPUT])


def check_message(data, stats):
    for check in (True, False):
        try:
            msg = ll.decode(data, check=check)
        except ll.MessageError:
            stats["refused" if check else "refused_unchecked"] += 1
            continue
        again = msg.encode(check=check)
        if again != data:
            raise AssertionError("%s decoded (check=%s) but encodes to other bytes (%d vs %d)"
                                 % (msg.TYPE_NAME, check, len(again), len(data)))
        # Bytes, not ==: a NaN (check=False lets some through) is never equal to itself.
        if type(msg).decode(again, check=check).encode(check=check) != data:
            raise AssertionError("%s: decode(encode(msg)) encodes to other bytes" % msg.TYPE_NAME)
        if not check:
            continue
        stats["decoded"] += 1
        try:  # the numpy views take what decode accepted, or name the problem
            if isinstance(msg, ll.scene_flow_t):
                arrays.flow_arrays(msg)
                arrays.pixel_grid(msg)
            elif isinstance(msg, ll.stereo_t):
                arrays.stereo_images(msg)
            elif isinstance(msg, ll.lidar_t):
                arrays.lidar_points(msg)
        except ll.MessageError:
            pass


def read_log(data, strict):
    with ll.LogReader(io.BytesIO(data), strict=strict) as log:
        return [(e.utime, e.channel, e.data) for e in log]


def check_log(data, stats):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ll.LogWarning)
        events = read_log(data, strict=False)
        try:
            strict = read_log(data, strict=True)
            if strict != events:
                raise AssertionError("strict reading gave other events than lenient reading of a clean log")
        except ll.LogFormatError:
            stats["log_irregular"] += 1
        try:
            for _ in ll.read_messages(io.BytesIO(data)):
                pass
        except ll.MessageError:
            pass
    stats["log_events"] += len(events)
    # The events read, written again, read back the same (channels longer than liblcm reads once
    # UTF-8 replacement characters widen them are left out: the writer refuses them).
    kept = [e for e in events if len(e[1].encode("utf-8")) <= eventlog.MAX_CHANNEL_BYTES]
    buf = io.BytesIO()
    w = ll.LogWriter(buf)
    for utime, channel, payload in kept:
        w.write(channel, payload, utime)
    if read_log(buf.getvalue(), strict=True) != kept:
        raise AssertionError("events written again read back differently")


def run(args):
    resource.setrlimit(resource.RLIMIT_AS, (args.memory_mib << 20, resource.getrlimit(resource.RLIMIT_AS)[1]))

    def on_alarm(*_):
        raise Hang("no result within %g s" % args.hang_seconds)

    signal.signal(signal.SIGALRM, on_alarm)
    # A warning (numpy's RuntimeWarning, say) is a finding too; only LogWarning is documented.
    warnings.simplefilter("error")
    rng = random.Random(args.seed)
    messages = message_seeds()
    logs = log_seeds(messages)
    corpus = messages + logs
    stats = dict.fromkeys(("decoded", "refused", "refused_unchecked", "log_events", "log_irregular"), 0)
    started = time.monotonic()
    done = 0
    next_report = started + 60
    while done < args.executions and time.monotonic() - started < args.seconds:
        is_log = rng.random() < 0.3
        data = mutate(rng.choice(logs if is_log else messages), rng, corpus)
        signal.setitimer(signal.ITIMER_REAL, args.hang_seconds)
        try:
            (check_log if is_log else check_message)(data, stats)
        except BaseException as e:  # anything but the documented errors is a finding
            signal.setitimer(signal.ITIMER_REAL, 0)
            if isinstance(e, KeyboardInterrupt):
                raise
            os.makedirs(args.findings, exist_ok=True)
            path = os.path.join(args.findings, "fuzz-lcm-%s.bin" % hashlib.sha1(data).hexdigest())
            with open(path, "wb") as f:
                f.write(data)
            with open(path + ".txt", "w") as f:
                f.write(("log" if is_log else "message") + "\n" + traceback.format_exc())
            traceback.print_exc()
            print("fuzz_lcm: FINDING after %d executions (%s input): %s" % (done, "log" if is_log else "message", path))
            return 1
        signal.setitimer(signal.ITIMER_REAL, 0)
        done += 1
        if time.monotonic() > next_report:
            next_report += 60
            print("fuzz_lcm: %d executions, %.0f/s" % (done, done / (time.monotonic() - started)), flush=True)
    seconds = time.monotonic() - started
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print("fuzz_lcm: %d executions in %.1f s (%.0f/s), seed %d, no finding; messages decoded %d, refused %d; "
          "log events read %d, irregular logs %d; peak RSS %.0f MiB"
          % (done, seconds, done / max(seconds, 1e-9), args.seed, stats["decoded"], stats["refused"],
             stats["log_events"], stats["log_irregular"], peak))
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--executions", type=int, default=10 ** 6)
    p.add_argument("--seconds", type=float, default=float("inf"), help="stop after this long even if short of N")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--findings", default=".")
    p.add_argument("--hang-seconds", type=float, default=10.0)
    p.add_argument("--memory-mib", type=int, default=4096)
    return run(p.parse_args())


if __name__ == "__main__":
    sys.exit(main())
