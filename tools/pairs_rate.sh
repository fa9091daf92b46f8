#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Pairs per second of `lidarflow sequence` on a 12-frame 1242x375 synthetic drive, as one stream
# and with frames in flight (2, 4, ... up to the thread count), at each thread count.
#   tools/pairs_rate.sh CLI PRESET [THREADS...]
# CLI: the lidarflow program; THREADS default to 1, 2 and every power of two up to the CPUs.
# Used by `tools/dev.sh pairs-rate` (the build's CLI) and tools/device_rates.sh (a carried one).
set -euo pipefail
[ $# -ge 2 ] || { sed -n '3,7p' "$0" >&2; exit 2; }
cli="$1" preset="$2"
shift 2
threads=("$@")
if [ ${#threads[@]} -eq 0 ]; then
    threads=(1 2)
    for ((t = 4; t <= $(nproc); t *= 2)); do threads+=("$t"); done
fi
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
"$cli" synth --drive "$dir/drive" --frames 12 --width 1242 --height 375 --seed 1 >/dev/null
printf '%-8s %-7s %-17s %s\n' preset threads frames_in_flight pairs/s
for t in "${threads[@]}"; do
    for ((f = 1; f <= t; f *= 2)); do
        rm -rf "$dir/out"
        line="$("$cli" sequence --drive "$dir/drive" --out "$dir/out" --preset "$preset" --threads "$t" \
            --frames-in-flight "$f" --poses none 2>/dev/null | grep -o '[0-9.]* pairs/s')"
        printf '%-8s %-7s %-17s %s\n' "$preset" "$t" "$f" "${line% pairs/s}"
    done
done
