#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Pairs per second on a many-core machine that has neither the project's Debian packages nor a
# network (the lent device machine): unpacks .device/lidarflow-device.tar.xz (made here by
# `tools/dev.sh device-bundle`), checks that every library the CLI needs resolves, and runs
# tools/pairs_rate.sh at `realtime` and `default`.
#   tools/device_rates.sh [THREADS...]   (default: 1, 2 and every power of two up to the CPUs)
# The table also goes to $OUT/pairs-rate.txt where OUT is set.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bundle="$root/.device/lidarflow-device.tar.xz"
[ -f "$bundle" ] || { echo "device_rates.sh: no $bundle: run tools/dev.sh device-bundle first" >&2; exit 1; }
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
if command -v xz >/dev/null; then
    xz -dc "$bundle" | tar -C "$dir" -xf -
else  # python3's tarfile reads xz without the xz program
    python3 -c 'import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2])' "$bundle" "$dir"
fi
export LD_LIBRARY_PATH="$dir/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
cli="$dir/bin/lidarflow"
if ldd "$cli" | grep 'not found' >&2; then
    echo "device_rates.sh: the libraries above are missing from the bundle and from this machine" >&2
    exit 1
fi
{
    echo "$(nproc) CPUs:$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2-); $("$cli" --version)"
    for preset in realtime default; do "$root/tools/pairs_rate.sh" "$cli" "$preset" "$@"; done
} | tee "${OUT:-$dir}/pairs-rate.txt"
