#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The player writes a file:// LCM log of a synthetic KITTI-layout folder; the log is replayed
# into an in-process bridge (lock-step, no drops) and every result must equal the C ABI's.
set -euo pipefail
: "${LIDARFLOW_CLI:?}" "${LIDARFLOW_LOG_CHECK:?}" "${LIDARFLOW_TEST_TMP:?}"
tmp="$LIDARFLOW_TEST_TMP/bridge_file_log"
rm -rf "$tmp" && mkdir -p "$tmp"
"$LIDARFLOW_CLI" synth --out "$tmp/scene" --width 320 --height 96 --frames 2 >/dev/null
"$LIDARFLOW_CLI" publish-kitti --root "$tmp/scene" --lidar paper --rate 0 --lcm-url "file://$tmp/in.log?mode=w"
opts=(--option matching.min_coarsest_height=16 --option threads=2)
# 2 ids = 2 sequences of 2 frames: 2 results (float32 is checked bit for bit in bridge_memq).
"$LIDARFLOW_LOG_CHECK" replay "$tmp/in.log" "${opts[@]}" --encoding int16 --step 2 --min-results 2
