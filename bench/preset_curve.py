#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Speed/accuracy curve of the estimator presets on the shared KITTI frames.

Runs bench_pipeline once per preset (KITTI frames only), then prints a Markdown table and
writes an SVG plot: x = seconds per frame pair (median of --runs, mean over the frames),
y = final SF outliers (mean over the frames), one point per preset plus OpenCV's
StereoSGBM + DISOpticalFlow baseline measured in the same runs.

    bench/preset_curve.py --bench build/bench/bench_pipeline --root KITTI_TRAINING \
        [--presets paper,balanced,default,fast,realtime] [--runs 3] [--threads 2] [--svg docs/preset_curve.svg]

Standard library only.
"""
import argparse
import os
import re
import statistics
import subprocess
import sys


def run_preset(bench, root, preset, runs, threads):
    cmd = [bench, "--root", root, "--runs", str(runs), "--threads", str(threads), "--preset", preset, "--no-synth"]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    frames = []
    for section in re.split(r"\n(?=kitti )", out)[1:]:
        total = re.search(r"^\s+total\s+([\d.]+) s\s+peak RSS (\d+) MiB", section, re.M)
        ours = re.search(r"^\s+lidarflow\s+D0\s+([\d.]+)\s+D1\s+([\d.]+)\s+Fl\s+([\d.]+)\s+SF\s+([\d.]+) %", section, re.M)
        base = re.search(r"^\s+OpenCV SGBM\+DIS\s+D0.*SF\s+([\d.]+) %\s+([\d.]+) s", section, re.M)
        if not (total and ours and base):
            sys.exit("preset_curve: cannot parse bench_pipeline output:\n" + section)
        frames.append({"seconds": float(total.group(1)), "rss": int(total.group(2)),
                       "d0": float(ours.group(1)), "d1": float(ours.group(2)), "fl": float(ours.group(3)),
                       "sf": float(ours.group(4)), "base_sf": float(base.group(1)), "base_s": float(base.group(2))})
    if not frames:
        sys.exit("preset_curve: bench_pipeline measured no KITTI frame (is --root right?)")
    mean = lambda k: statistics.mean(f[k] for f in frames)
    return {"preset": preset, "seconds": mean("seconds"), "rss": max(f["rss"] for f in frames),
            "d0": mean("d0"), "d1": mean("d1"), "fl": mean("fl"), "sf": mean("sf"),
            "base_sf": mean("base_sf"), "base_s": mean("base_s"), "frames": len(frames)}


def svg(points, baseline, threads):
    w, h, left, right, top, bottom = 640, 400, 70, 30, 40, 60
    xs = [p["seconds"] for p in points] + [baseline[0]]
    ys = [p["sf"] for p in points] + [baseline[1]]
    xmax = max(xs) * 1.15
    ymin, ymax = 0.0, max(ys) * 1.15
    px = lambda x: left + (w - left - right) * x / xmax
    py = lambda y: h - bottom - (h - top - bottom) * (y - ymin) / (ymax - ymin)
    s = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
         f'<rect width="{w}" height="{h}" fill="white"/>',
         f'<text x="{w / 2}" y="20" text-anchor="middle" font-size="14">lidarflow presets, KITTI 2015 (shared frames), '
         f'{threads} threads</text>',
         f'<line x1="{left}" y1="{h - bottom}" x2="{w - right}" y2="{h - bottom}" stroke="black"/>',
         f'<line x1="{left}" y1="{top}" x2="{left}" y2="{h - bottom}" stroke="black"/>']
    for i in range(6):
        x = xmax * i / 5
        s.append(f'<text x="{px(x):.1f}" y="{h - bottom + 18}" text-anchor="middle">{x:.1f}</text>')
        y = ymin + (ymax - ymin) * i / 5
        s.append(f'<text x="{left - 8}" y="{py(y) + 4:.1f}" text-anchor="end">{y:.0f}</text>')
        s.append(f'<line x1="{left}" y1="{py(y):.1f}" x2="{w - right}" y2="{py(y):.1f}" stroke="#ddd"/>')
    s.append(f'<text x="{(left + w - right) / 2}" y="{h - 15}" text-anchor="middle">seconds per frame pair</text>')
    s.append(f'<text x="18" y="{(top + h - bottom) / 2}" text-anchor="middle" '
             f'transform="rotate(-90 18 {(top + h - bottom) / 2})">final SF outliers [%]</text>')
    path = " ".join(f'{px(p["seconds"]):.1f},{py(p["sf"]):.1f}' for p in sorted(points, key=lambda p: p["seconds"]))
    s.append(f'<polyline points="{path}" fill="none" stroke="#1f77b4" stroke-width="2"/>')
    for p in points:
        s.append(f'<circle cx="{px(p["seconds"]):.1f}" cy="{py(p["sf"]):.1f}" r="5" fill="#1f77b4"/>')
        s.append(f'<text x="{px(p["seconds"]) + 8:.1f}" y="{py(p["sf"]) - 8:.1f}">{p["preset"]}</text>')
    bx, by = px(baseline[0]), py(baseline[1])
    s.append(f'<rect x="{bx - 5:.1f}" y="{by - 5:.1f}" width="10" height="10" fill="#d62728"/>')
    s.append(f'<text x="{bx + 8:.1f}" y="{by + 4:.1f}">OpenCV SGBM+DIS</text>')
    s.append("</svg>")
    return "\n".join(s) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bench", required=True)
    ap.add_argument("--root", default=os.environ.get("LIDARFLOW_KITTI_DIR", ""))
    ap.add_argument("--presets", default="paper,balanced,default,fast,realtime")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--svg", default="")
    a = ap.parse_args()
    if not a.root:
        sys.exit("preset_curve: --root (or LIDARFLOW_KITTI_DIR) is required")
    points = [run_preset(a.bench, a.root, p, a.runs, a.threads) for p in a.presets.split(",")]
    print(f"| preset | s / frame pair ({a.threads} threads) | peak RSS | D0 | D1 | Fl | SF |")
    print("|---|---|---|---|---|---|---|")
    for p in points:
        print(f'| `{p["preset"]}` | {p["seconds"]:.2f} | {p["rss"]} MiB | {p["d0"]:.2f} | {p["d1"]:.2f} | '
              f'{p["fl"]:.2f} | {p["sf"]:.2f} |')
    base = (statistics.mean(p["base_s"] for p in points), statistics.mean(p["base_sf"] for p in points))
    print(f"| OpenCV SGBM+DIS | {base[0]:.2f} | | | | | {base[1]:.2f} |")
    if a.svg:
        with open(a.svg, "w") as f:
            f.write(svg(points, base, a.threads))
        print(f"wrote {a.svg}")


if __name__ == "__main__":
    main()
