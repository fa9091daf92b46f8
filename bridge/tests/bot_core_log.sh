#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# End to end on a log as bot_core-typed drivers record it, made by an independent generator
# (make_bot_core_log: lcm-gen's C encoders + liblcm's lcm_eventlog writer, no lidarflow code):
# lidarflow-lcm-bridge --replay turns it into a result log with every frame processed (exit 0),
# every LiDAR sweep paired, the foreign channel left out, and every result equal to the C ABI's
# on the same frames (log_check verify reads the inputs with lcm-gen's decoder).
set -euo pipefail
: "${LIDARFLOW_BRIDGE:?}" "${LIDARFLOW_LOG_CHECK:?}" "${LIDARFLOW_MAKE_BOT_CORE_LOG:?}" "${LIDARFLOW_TEST_TMP:?}"
tmp="$LIDARFLOW_TEST_TMP/bridge_bot_core_log"
rm -rf "$tmp" && mkdir -p "$tmp"
fail() { echo "FAIL: $*"; exit 1; }
frames=4
l2c=$("$LIDARFLOW_MAKE_BOT_CORE_LOG" "$tmp/in.log" "$tmp" "$frames")
opts=(--option matching.min_coarsest_height=16 --option threads=2)
inputs=(--stereo-channel STEREO_CAMERA --lidar-channel VELODYNE_POINTS --calib "$tmp/calib_cam_to_cam.txt"
        --lidar-to-camera "$l2c")

"$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/out.log" "${inputs[@]}" "${opts[@]}" 2>"$tmp/replay.err" \
    || { rc=$?; cat "$tmp/replay.err"; fail "replay exited $rc"; }
cat "$tmp/replay.err"
grep -q "events (stereo $frames, lidar $frames, calibration 0, other channels $frames, left out); stereo processed $frames, dropped 0, missing from the log 0; lidar malformed 0, rejected 0" \
    "$tmp/replay.err" || fail "not every frame / sweep accounted for"
"$LIDARFLOW_LOG_CHECK" verify "$tmp/out.log" --inputs "$tmp/in.log" "${inputs[@]}" "${opts[@]}" \
    --min-results $((frames - 1)) | tee "$tmp/check.out"
grep -q "($((frames - 1)) with LiDAR)" "$tmp/check.out" || fail "results without LiDAR"
echo "bot_core_log: ok"
