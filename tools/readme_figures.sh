#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The README's demo table, taken from a run of `lidarflow demo` (deterministic: same table on
# every machine and thread count) instead of typed by hand. The table sits between the lines
# <!-- demo-table: begin --> and <!-- demo-table: end --> of README.md; the `seconds` column is
# left out (it is the one figure of the demo that depends on the machine).
#   tools/readme_figures.sh [LIDARFLOW]          rewrite the README's table from a demo run
#   tools/readme_figures.sh --check [LIDARFLOW]  exit 1 (and show the difference) when the
#                                                README's table is not what the demo prints
# LIDARFLOW: the `lidarflow` program (default: build/tools/lidarflow/lidarflow).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
check=0
if [ "${1:-}" = "--check" ]; then check=1; shift; fi
cli="${1:-$root/build/tools/lidarflow/lidarflow}"
readme="${README:-$root/README.md}"
[ -x "$cli" ] || { echo "readme_figures: no lidarflow program at $cli (build it, or pass its path)"; exit 2; }
begin='<!-- demo-table: begin -->' end='<!-- demo-table: end -->'
grep -qxF "$begin" "$readme" && grep -qxF "$end" "$readme" ||
    { echo "readme_figures: $readme has no $begin ... $end block"; exit 2; }

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
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
[ "$(wc -l <"$tmp/table.md")" -ge 5 ] || { cat "$tmp/demo.txt"; echo "readme_figures: no score table in the demo's output"; exit 2; }

# The README with the block between the markers replaced by the fresh table.
awk -v begin="$begin" -v end="$end" -v table="$tmp/table.md" '
    $0 == begin { print; while ((getline line < table) > 0) print line; skip = 1; next }
    $0 == end { skip = 0 }
    !skip' "$readme" >"$tmp/README.md"

if [ "$check" = 1 ]; then
    if cmp -s "$readme" "$tmp/README.md"; then
        echo "readme_figures: the README's demo table is what lidarflow demo prints"
        exit 0
    fi
    diff -u "$readme" "$tmp/README.md" || true
    echo "readme_figures: the README's demo table differs from lidarflow demo (tools/readme_figures.sh rewrites it)"
    exit 1
fi
cp "$tmp/README.md" "$readme"
echo "readme_figures: wrote the demo table into $readme"
