#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The README's figures, taken from runs instead of typed by hand:
# - the demo table (between <!-- demo-table: begin --> and <!-- demo-table: end -->), from
#   `lidarflow demo` (deterministic: the same table on every machine and thread count; the
#   `seconds` column, the one machine-dependent figure, is left out);
# - with --kitti, the KITTI results table (between <!-- kitti-table: begin --> and
#   <!-- kitti-table: end -->), from three `lidarflow kitti` runs on $LIDARFLOW_KITTI_DIR
#   (ablation over seeds 1-8, the raw Velodyne scan over seeds 1-8, 8 placements x seeds 1-2;
#   about 15 minutes on 2 cores), formatted by tools/readme_kitti_table.py.
#   tools/readme_figures.sh [--check] [--kitti] [LIDARFLOW]
#     rewrite the README's table (--check: exit 1 and show the difference when the README's
#     table is not what the run prints; nothing is written)
# LIDARFLOW: the `lidarflow` program (default: build/tools/lidarflow/lidarflow).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
check=0 kitti=0
while [ $# -gt 0 ]; do
    case "$1" in
        --check) check=1; shift ;;
        --kitti) kitti=1; shift ;;
        *) break ;;
    esac
done
cli="${1:-$root/build/tools/lidarflow/lidarflow}"
readme="${README:-$root/README.md}"
[ -x "$cli" ] || { echo "readme_figures: no lidarflow program at $cli (build it, or pass its path)"; exit 2; }
if [ "$kitti" = 1 ]; then name=kitti-table; else name=demo-table; fi
begin="<!-- $name: begin -->" end="<!-- $name: end -->"
grep -qxF "$begin" "$readme" && grep -qxF "$end" "$readme" ||
    { echo "readme_figures: $readme has no $begin ... $end block"; exit 2; }

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
if [ "$kitti" = 1 ]; then
    [ -n "${LIDARFLOW_KITTI_DIR:-}" ] || { echo "readme_figures: --kitti needs LIDARFLOW_KITTI_DIR"; exit 2; }
    runs=("ablation:--preset paper --lidar paper --ablation --seeds 8" "velodyne:--preset paper --lidar velodyne --seeds 8"
          "placements:--preset paper --lidar paper --placements 8 --seeds 2")
    for r in "${runs[@]}"; do
        echo "readme_figures: lidarflow kitti ${r#*:}"
        # shellcheck disable=SC2086  # the run's options are words
        "$cli" kitti --root "$LIDARFLOW_KITTI_DIR" ${r#*:} --no-viz >"$tmp/${r%%:*}.txt" \
            2>"$tmp/kitti.err" || { cat "$tmp/kitti.err"; echo "readme_figures: lidarflow kitti ${r#*:} failed"; exit 2; }
    done
    /usr/bin/python3 "$root/tools/readme_kitti_table.py" "$tmp/ablation.txt" "$tmp/velodyne.txt" \
        "$tmp/placements.txt" >"$tmp/table.md"
else
    "$cli" demo --out "$tmp/demo-out" >"$tmp/demo.txt" 2>"$tmp/demo.err" ||
        { cat "$tmp/demo.err"; echo "readme_figures: lidarflow demo failed"; exit 2; }
    # The score table: its title line and the lines after it up to the first empty one, without
    # the last column (seconds).
    {
        echo '```'
        awk '/^KITTI outliers/ { print; on = 1; next }
             on && /^$/ { exit }
             on { sub(/[ \t]+[^ \t]+$/, ""); print }' "$tmp/demo.txt"
        echo '```'
    } >"$tmp/table.md"
    [ "$(wc -l <"$tmp/table.md")" -ge 5 ] ||
        { cat "$tmp/demo.txt"; echo "readme_figures: no score table in the demo's output"; exit 2; }
fi

# The README with the block between the markers replaced by the fresh table.
awk -v begin="$begin" -v end="$end" -v table="$tmp/table.md" '
    $0 == begin { print; while ((getline line < table) > 0) print line; skip = 1; next }
    $0 == end { skip = 0 }
    !skip' "$readme" >"$tmp/README.md"

if [ "$check" = 1 ]; then
    if cmp -s "$readme" "$tmp/README.md"; then
        echo "readme_figures: the README's $name is what lidarflow prints"
        exit 0
    fi
    diff -u "$readme" "$tmp/README.md" || true
    echo "readme_figures: the README's $name differs from lidarflow's run (tools/readme_figures.sh rewrites it)"
    exit 1
fi
cp "$tmp/README.md" "$readme"
echo "readme_figures: wrote the $name into $readme"
