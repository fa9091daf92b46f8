#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""The README's KITTI results table, built from the printed reports of three `lidarflow kitti`
runs (tools/readme_figures.sh --kitti makes them):

  readme_kitti_table.py ABLATION.txt VELODYNE.txt PLACEMENTS.txt

ABLATION: --lidar paper --ablation --seeds K; VELODYNE: --lidar velodyne --seeds K; PLACEMENTS:
--lidar paper --placements P --seeds S. Prints the markdown table and the placement line.
Only the paper's own figures (in brackets) are typed here: they are the reference, not a result.
"""
import decimal
import re
import sys

# README row: (stage, label, report group, report variant, paper SF, paper density, show mean)
ROWS = [
    ("matching", "image-only", "Matching", "im-only", "39.09", None, False),
    ("matching", "LiDAR-Flow", "Matching", "LiDAR-Flow", "38.46", None, False),
    ("consistency", "image-only", "Consist. Check", "image-only", "5.04", "40.9", False),
    ("consistency", "LiDAR-Flow", "Consist. Check", "disp+LiDAR & backward+LiDAR", "4.21", "37.3", False),
    ("sparsification", "LiDAR-Flow", "Interpolation", "Spars+LiDAR", "6.01", "5.8", False),
    ("final", "Interp-only", "Interpolation", "Spars+LiDAR & Interp-only", "12.27", None, False),
    ("final", "**LiDAR-Flow**", "Interpolation", "LiDAR-Flow (Spars+LiDAR & Interp+LiDAR)", "11.52", None, True),
    ("final", "image-only pipeline", "Interpolation", "image-only", "SFF++ 14.51", None, True),
]
VELODYNE_ROW = ("final", "LiDAR-Flow, real Velodyne scan (`--lidar velodyne`)", "Interpolation", "LiDAR-Flow")

SEED_LINE = re.compile(r"(-?\d+\.\d+) \+-\s*(\d+\.\d+)")


def fail(message):
    sys.exit("readme_kitti_table: " + message)


def table_one(text, what):
    """{(group, variant): [D0, D1, Fl, SF, density]} from a report's Table I (seed 1)."""
    lines = text.splitlines()
    start = next((i for i, l in enumerate(lines) if l.startswith("Table I ")), None)
    if start is None:
        fail(what + ": no Table I in the report")
    rows, group = {}, ""
    for line in lines[start + 3:]:
        if not line.strip():
            break
        group = line[:16].strip() or group
        numbers = line[58:].split()
        if len(numbers) != 8:
            fail(what + ": unexpected Table I line: " + line)
        rows[(group, line[16:58].strip())] = [float(x) for x in numbers[3:]]
    return rows


def seed_summary(text, what):
    """{(name truncated as printed, frame): SF mean} from the report's per-seed summary."""
    lines = text.splitlines()
    start = next((i for i, l in enumerate(lines) if l.startswith("Over ")), None)
    if start is None:
        fail(what + ": no per-seed summary in the report (was --seeds given?)")
    out = {}
    for line in lines[start + 2:]:
        if not line.strip():
            break
        cells = SEED_LINE.findall(line[61:])
        if len(cells) != 4:
            fail(what + ": unexpected summary line: " + line)
        out[(line[:52].strip(), line[53:61].strip())] = float(cells[3][0])
    return out


def per_frame(summary, group, variant, what):
    name = (group + ": " + variant)[:52]
    frames = sorted(f for (n, f) in summary if n == name)
    if not frames:
        fail(what + ": no per-seed rows for " + name)
    return [summary[(name, f)] for f in frames]


def mean_of_printed(values):
    """The mean of figures as printed (2 decimals), rounded half up as a reader would."""
    total = sum(decimal.Decimal("%.2f" % v) for v in values)
    return str((total / len(values)).quantize(decimal.Decimal("0.01"), rounding=decimal.ROUND_HALF_UP))


def row_line(stage, label, scores, paper_sf, paper_density, frames, show_mean):
    d0, d1, fl, sf, density = scores
    sf_text = "**%.2f**" % sf if label.startswith("**") else "%.2f" % sf
    if paper_sf:
        sf_text += " (%s)" % paper_sf
    density_text = "%.1f" % density if density < 99.95 else "100"
    if paper_density:
        density_text += " (%s)" % paper_density
    seeds = " / ".join("%.2f" % x for x in frames)
    if show_mean:
        mean = mean_of_printed(frames)
        seeds += " (mean **%s**)" % mean if label.startswith("**") else " (mean %s)" % mean
    return "| %s | %s | %.2f | %.2f | %.2f | %s | %s | %s |" % (stage, label, d0, d1, fl, sf_text, density_text, seeds)


def main(argv):
    if len(argv) != 4:
        sys.exit(__doc__)
    texts = []
    for path in argv[1:]:
        with open(path, encoding="utf-8") as f:
            texts.append(f.read())
    ablation, velodyne, placements = texts
    table = table_one(ablation, "ablation")
    seeds = seed_summary(ablation, "ablation")
    m = re.search(r"^Over (\d+) seeds:", ablation, re.M)
    if not m:
        fail("ablation: no 'Over K seeds' summary")
    frame_ids = sorted({f for (_, f) in seeds})
    print("| stage | variant | D0 | D1 | Fl | SF | density [%%] | SF, seeds 1-%s: %s |" % (m.group(1), " / ".join(frame_ids)))
    print("|---|---|---|---|---|---|---|---|")
    for stage, label, group, variant, paper_sf, paper_density, show_mean in ROWS:
        if (group, variant) not in table:
            fail("ablation: no Table I row %s / %s" % (group, variant))
        print(row_line(stage, label, table[(group, variant)], paper_sf, paper_density,
                       per_frame(seeds, group, variant, "ablation"), show_mean))
    stage, label, group, variant = VELODYNE_ROW
    vtable = table_one(velodyne, "velodyne")
    if (group, variant) not in vtable:
        fail("velodyne: no Table I row %s / %s" % (group, variant))
    print(row_line(stage, label, vtable[(group, variant)], None, None,
                   per_frame(seed_summary(velodyne, "velodyne"), group, variant, "velodyne"), True))
    header = next((l for l in placements.splitlines() if l.startswith("Over ")), "")
    m = re.match(r"Over (\d+) seed\(s\) x (\d+) LiDAR placements", header)
    if not m:
        fail("placements: no 'Over S seed(s) x P LiDAR placements' summary")
    frames = per_frame(seed_summary(placements, "placements"), "Interpolation", "LiDAR-Flow", "placements")
    print()
    print("Over %s placements of the sampling grids x %s seed(s) (`--placements %s --seeds %s`) the final SF is "
          "**%s %%**." % (m.group(2), m.group(1), m.group(2), m.group(1), mean_of_printed(frames)))


if __name__ == "__main__":
    main(sys.argv)
