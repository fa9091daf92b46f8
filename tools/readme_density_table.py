#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The README's preset x LiDAR density table: final SF outliers [%] per preset with the paper's
88 points (mean over seeds 1..K) and with the real Velodyne scan thinned to 16 and 32 beams and
whole (64), each with the preset's time as a multiple of OpenCV's StereoSGBM + DISOpticalFlow
(bench_pipeline --runs 3 --no-synth, mean of the frames' ratios).

    tools/readme_density_table.py --cli build/tools/lidarflow/lidarflow \
        --bench build/bench/bench_pipeline --root KITTI_TRAINING [--seeds 8] [--threads 2] \
        [--presets paper,default,fast,realtime] [--write README.md]

Prints the Markdown table; --write replaces the lines between <!-- density-table: begin -->
and <!-- density-table: end --> of that file. Standard library only.
"""
import argparse
import re
import statistics
import subprocess
import sys

BEGIN, END = "<!-- density-table: begin -->", "<!-- density-table: end -->"


def kitti_sf(cli, root, preset, threads, extra):
    """Mean over frames of the final SF outliers (per-frame means when --seeds is given)."""
    cmd = [cli, "kitti", "--root", root, "--preset", preset, "--threads", str(threads), "--no-viz"] + extra
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    if "--seeds" in extra:  # per frame, the mean over the seeds: the last column of that block
        block = out.split("Over ", 1)[-1]
        per_frame = [float(v) for v in re.findall(r"^Interpolation: LiDAR-Flow\s+\d{6}.*?([\d.]+) \+-[\d.]+\s*$",
                                                   block, re.M)]
    else:  # per frame (occ / noc), then the pooled pair
        m = re.search(r"^Interpolation: LiDAR-Flow\s+(.*)$", out, re.M)
        per_frame = [float(a) for a in re.findall(r"([\d.]+) / [\d.]+", m.group(1))][:-1] if m else []
    if not per_frame:
        sys.exit("readme_density_table: no per-frame SF in:\n" + out)
    return statistics.mean(per_frame)


def time_ratio(bench, root, preset, threads):
    cmd = [bench, "--root", root, "--runs", "3", "--threads", str(threads), "--preset", preset, "--no-synth"]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    ratios = [float(r) for r in re.findall(r"time ratio lidarflow / baseline: ([\d.]+)x", out)]
    if not ratios:
        sys.exit("readme_density_table: no time ratio in:\n" + out)
    return statistics.mean(ratios)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", required=True)
    ap.add_argument("--bench", required=True)
    ap.add_argument("--root", required=True)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--presets", default="paper,default,fast,realtime")
    ap.add_argument("--write")
    a = ap.parse_args()
    rows = ["| preset | 88 points (seeds 1-%d) | 16 beams | 32 beams | 64 beams (the scan) | time |" % a.seeds,
            "|---|---|---|---|---|---|"]
    for preset in a.presets.split(","):
        cells = ["%.2f %%" % kitti_sf(a.cli, a.root, preset, a.threads, ["--lidar", "paper", "--seeds", str(a.seeds)])]
        for beams in (16, 32, 0):
            extra = ["--lidar", "velodyne"] + (["--beams", str(beams)] if beams else [])
            cells.append("%.2f %%" % kitti_sf(a.cli, a.root, preset, a.threads, extra))
        cells.append("%.1fx" % time_ratio(a.bench, a.root, preset, a.threads))
        rows.append("| `%s` | %s |" % (preset, " | ".join(cells)))
        print(rows[-1], file=sys.stderr, flush=True)
    table = "\n".join(rows)
    print(table)
    if a.write:
        text = open(a.write, encoding="utf-8").read()
        if BEGIN not in text or END not in text:
            sys.exit("readme_density_table: %s has no %s ... %s markers" % (a.write, BEGIN, END))
        head, rest = text.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        with open(a.write, "w", encoding="utf-8") as f:
            f.write(head + BEGIN + "\n" + table + "\n" + END + tail)


if __name__ == "__main__":
    main()
