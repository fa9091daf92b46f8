#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# lidarflow-lcm-bridge --replay --frames A:B --warm-up N on one continuous stream (a bot_core log
# of 6 frames from the independent generator: a box moving in front of a background the camera
# drives towards). Each pair takes priors from the pair before it, so a part of a log replayed
# cold differs from the whole log's replay; warmed up from the log's first frame it must give
# the whole replay's results byte for byte:
#  1. --frames 3:5 --warm-up 3 (and 1000: as far as the log goes) publish exactly the whole
#     replay's pairs (3,4) and (4,5), byte for byte in the planes; the warm-up's pairs are
#     computed, not written or counted, and the summary says how many warm-up frames were fed;
#  2. the same part without warm-up differs (the check can fail), and --warm-up 0 is that cold
#     part byte for byte; --warm-up without --frames is the whole replay.
set -euo pipefail
: "${LIDARFLOW_BRIDGE:?}" "${LIDARFLOW_LOG_CHECK:?}" "${LIDARFLOW_MAKE_BOT_CORE_LOG:?}" "${LIDARFLOW_TEST_TMP:?}"
tmp="$LIDARFLOW_TEST_TMP/bridge_replay_warm_up"
rm -rf "$tmp" && mkdir -p "$tmp"
fail() { echo "FAIL: $*"; exit 1; }
l2c=$("$LIDARFLOW_MAKE_BOT_CORE_LOG" "$tmp/in.log" "$tmp" 6)
args=(--stereo-channel STEREO_CAMERA --lidar-channel VELODYNE_POINTS --calib "$tmp/calib_cam_to_cam.txt"
      --lidar-to-camera "$l2c" --option matching.min_coarsest_height=16 --option threads=2 --quiet)
# replay NAME ARGS...: the replay must exit 0; its stderr in NAME.err.
replay() {
    local name="$1"; shift
    "$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/$name.log" "${args[@]}" "$@" 2>"$tmp/$name.err" \
        || { rc=$?; cat "$tmp/$name.err"; fail "replay $* exited $rc"; }
}

replay whole
grep -q "stereo processed 6, dropped 0.*; 5 results," "$tmp/whole.err" || { cat "$tmp/whole.err"; fail "whole log: not 5 results"; }
# The whole replay's results of pairs (3,4) and (4,5).
"$LIDARFLOW_LOG_CHECK" edit "$tmp/whole.log" "$tmp/whole_3_5.log" --drop LIDARFLOW_FLOW:0 --drop LIDARFLOW_FLOW:1 \
    --drop LIDARFLOW_FLOW:2 >/dev/null

for n in 3 1000; do
    replay "warm$n" --frames 3:5 --warm-up "$n"
    cat "$tmp/warm$n.err"
    grep -q "stereo processed 3, dropped 0.*; 2 results," "$tmp/warm$n.err" || fail "--warm-up $n: the warm-up counted or published"
    grep -q "frames 3:5: 3 stereo frame(s) before the range, warm-up $n: the last 3 handed over, 3 fed to the estimator, 3 pairs computed and not written" \
        "$tmp/warm$n.err" || fail "--warm-up $n: the summary does not say what the warm-up fed"
    "$LIDARFLOW_LOG_CHECK" compare "$tmp/warm$n.log" "$tmp/whole_3_5.log" --bytes \
        || fail "--frames 3:5 --warm-up $n: not the whole replay's results byte for byte"
done

replay cold --frames 3:5
grep -q "frames 3:5: 3 stereo frame(s) before the range not computed" "$tmp/cold.err" || fail "cold part: summary line"
if "$LIDARFLOW_LOG_CHECK" compare "$tmp/cold.log" "$tmp/whole_3_5.log" --bytes >/dev/null 2>&1; then
    fail "--frames 3:5 without warm-up equals the whole replay: the stream carries nothing, the test proves nothing"
fi
replay warm0 --frames 3:5 --warm-up 0
"$LIDARFLOW_LOG_CHECK" compare "$tmp/warm0.log" "$tmp/cold.log" --bytes >/dev/null || fail "--warm-up 0 changed the results"
grep -q "frames 3:5: 3 stereo frame(s) before the range not computed" "$tmp/warm0.err" || fail "--warm-up 0: summary line"
replay nowindow --warm-up 3
"$LIDARFLOW_LOG_CHECK" compare "$tmp/nowindow.log" "$tmp/whole.log" --bytes >/dev/null \
    || fail "--warm-up without --frames changed the results"
grep -q "stereo processed 6, dropped 0.*; 5 results," "$tmp/nowindow.err" || fail "--warm-up without --frames: summary"
grep -q "warm-up" "$tmp/nowindow.err" && fail "--warm-up without --frames: a warm-up reported"
echo "replay_warm_up: ok"
