#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# lidarflow-lcm-bridge --replay: a file:// log written by the player becomes a result log.
#  1. every frame processed (exit 0), every result equal to the C ABI's (log_check verify with
#     the inputs from the input log), the final status accounting for every stereo frame;
#  2. lcm-logplayer plays the result log (into a file:// log, no network) and the played copy
#     passes the same check;
#  3. --frames A:B replays stereo frames A..B only: their pairs, equal to the whole log's;
#  4. logs with a frame missing (frame_number gap) or a calibration missing (frames before any
#     calibration) exit 3 and name the frames;
#     With --warm-up, frames missing or dropped before the range are not the range's (exit 0);
#  5. piped, publish-kitti and --replay write progress lines with elapsed time and ETA; --quiet
#     silences them.
set -euo pipefail
: "${LIDARFLOW_CLI:?}" "${LIDARFLOW_BRIDGE:?}" "${LIDARFLOW_LOG_CHECK:?}" "${LIDARFLOW_TEST_TMP:?}"
tmp="$LIDARFLOW_TEST_TMP/bridge_replay_log"
rm -rf "$tmp" && mkdir -p "$tmp"
fail() { echo "FAIL: $*"; exit 1; }
"$LIDARFLOW_CLI" synth --out "$tmp/scene" --width 320 --height 96 --frames 2 >/dev/null
# 2 ids x 2 loops = 4 sequences of 2 frames = 8 frames, 4 results.
"$LIDARFLOW_CLI" publish-kitti --root "$tmp/scene" --lidar paper --rate 0 --loop 2 \
    --lcm-url "file://$tmp/in.log?mode=w" 2>"$tmp/publish.err"
cat "$tmp/publish.err"
grep -q "^publish-kitti: \[1/8\] 000000_10, loop 1  (elapsed .*, ETA .*)$" "$tmp/publish.err" || fail "no first progress line"
grep -q "^publish-kitti: \[8/8\] 000001_11, loop 2  (elapsed .*, ETA 0.0 s)$" "$tmp/publish.err" || fail "no last progress line"
"$LIDARFLOW_CLI" publish-kitti --root "$tmp/scene" --lidar paper --rate 0 --quiet \
    --lcm-url "file://$tmp/quiet.log?mode=w" 2>"$tmp/publish_quiet.err"
[ ! -s "$tmp/publish_quiet.err" ] || fail "publish-kitti --quiet wrote to stderr"
opts=(--option matching.min_coarsest_height=16 --option threads=2)

"$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/out.log" "${opts[@]}" 2>"$tmp/replay.err" \
    || { rc=$?; cat "$tmp/replay.err"; fail "replay exited $rc"; }
cat "$tmp/replay.err"
grep -q "stereo processed 8, dropped 0, missing from the log 0" "$tmp/replay.err" || fail "not every frame processed"
grep -q "^lidarflow-lcm-bridge: input quality of the results: [0-9]* ok" "$tmp/replay.err" || fail "no input quality in the summary"
grep -q "^lidarflow-lcm-bridge: replay: stereo frame 1, [0-9]* % of the log  (elapsed .*, ETA .*)$" "$tmp/replay.err" \
    || fail "no replay progress line"
grep -q "^lidarflow-lcm-bridge: replay: stereo frame 8, 100 % of the log  (elapsed .*, ETA 0.0 s)$" "$tmp/replay.err" \
    || fail "no last replay progress line"
"$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/quiet_out.log" "${opts[@]}" --quiet 2>"$tmp/quiet.err" \
    || fail "replay --quiet failed"
grep -q "replay: stereo frame" "$tmp/quiet.err" && fail "replay --quiet wrote progress lines"
grep -q "stereo processed 8" "$tmp/quiet.err" || fail "replay --quiet lost its summary"
"$LIDARFLOW_LOG_CHECK" verify "$tmp/out.log" --inputs "$tmp/in.log" "${opts[@]}" --min-results 4

if command -v lcm-logplayer >/dev/null; then
    lcm-logplayer -s 100 -l "file://$tmp/played.log?mode=w" "$tmp/out.log"
    "$LIDARFLOW_LOG_CHECK" verify "$tmp/played.log" --inputs "$tmp/in.log" "${opts[@]}" --min-results 4
else
    echo "lcm-logplayer not installed: playing the result log not checked"
fi

# Frames 3..7: frame 3 is the second of sequence 1, so its pair (2, 3) is left out and the
# range's pairs are those of sequences 2 and 3.
"$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/range.log" --frames 3:7 "${opts[@]}" 2>"$tmp/range.err" \
    || { rc=$?; cat "$tmp/range.err"; fail "replay --frames 3:7 exited $rc"; }
cat "$tmp/range.err"
grep -q "stereo processed 5, dropped 0" "$tmp/range.err" || fail "--frames 3:7: not frames 3..7 processed"
grep -q "; 2 results," "$tmp/range.err" || fail "--frames 3:7: not 2 results"
grep -q "3 stereo frame(s) before the range" "$tmp/range.err" || fail "--frames 3:7: frames before not counted"
"$LIDARFLOW_LOG_CHECK" edit "$tmp/out.log" "$tmp/out_tail.log" --drop LIDARFLOW_FLOW:0 --drop LIDARFLOW_FLOW:1
"$LIDARFLOW_LOG_CHECK" compare "$tmp/range.log" "$tmp/out_tail.log" || fail "--frames 3:7: not the whole log's results"
# A range past the log's end (8 frames: 0..7), e.g. a source that shrank since it was counted:
# exit 3 and a LOST line naming the range and the log's frame count, never exit 0.
for range in 3:9 10:12; do
    set +e
    "$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/x.log" --frames "$range" "${opts[@]}" 2>"$tmp/past.err"
    rc=$?
    set -e
    [ "$rc" = 3 ] || { cat "$tmp/past.err"; fail "--frames $range past the log's 8 frames exited $rc, expected 3"; }
    grep -q "LOST: frames $range: the log has only 8 stereo frame(s)" "$tmp/past.err" || { cat "$tmp/past.err"; fail "--frames $range: no LOST line with the log's frame count"; }
    grep -q "the log ended after 8 stereo frame(s)" "$tmp/past.err" || fail "--frames $range: the summary does not say how many frames the log had"
    [ "$range" != 3:9 ] || grep -q "frames 8..9 missing" "$tmp/past.err" || fail "--frames 3:9: the missing frames not named"
done
for bad in 3:3 5:2 -1:4 3: x; do
    "$LIDARFLOW_BRIDGE" --replay "$tmp/in.log" --out "$tmp/x.log" --frames "$bad" 2>/dev/null && fail "--frames $bad accepted"
    [ $? = 2 ] || fail "--frames $bad: not a usage error"
done

expect_lost() {  # LOG PATTERN...
    local log="$1"; shift
    set +e
    "$LIDARFLOW_BRIDGE" --replay "$log" --out "$tmp/bad_out.log" "${opts[@]}" 2>"$tmp/bad.err"
    local rc=$?
    set -e
    cat "$tmp/bad.err"
    [ "$rc" = 3 ] || fail "replay of $log exited $rc, expected 3"
    for pattern in "$@"; do grep -q -- "$pattern" "$tmp/bad.err" || fail "no line '$pattern'"; done
}
# The third stereo event left out: the log lacks frame_number 2.
"$LIDARFLOW_LOG_CHECK" edit "$tmp/in.log" "$tmp/gap.log" --drop LIDARFLOW_STEREO:2
expect_lost "$tmp/gap.log" "LOST: 1 frame(s) missing from the log before stereo frame .*frame_number 3"
# The first calibration left out: both frames of the first sequence come before any calibration.
"$LIDARFLOW_LOG_CHECK" edit "$tmp/in.log" "$tmp/nocal.log" --drop LIDARFLOW_CALIB:0
expect_lost "$tmp/nocal.log" "LOST: stereo frame .*sequence 0, frame_number 0.* dropped: no calibration" \
    "LOST: stereo frame .*sequence 0, frame_number 1.* dropped: no calibration"
# --warm-up: a warm-up frame's problems are not the range's. The gap (frame_number 2 missing) lies
# between warm-up frames 1 and 3, the frames of sequence 0 (before any calibration) are all
# warm-up: the range is complete (exit 0), and the summary counts what the warm-up fed.
expect_warm_up() {  # LOG FRAMES WARM_UP PROCESSED SUMMARY
    "$LIDARFLOW_BRIDGE" --replay "$1" --out "$tmp/warm_out.log" --frames "$2" --warm-up "$3" "${opts[@]}" 2>"$tmp/warm.err" \
        || { rc=$?; cat "$tmp/warm.err"; fail "replay of $1 --frames $2 --warm-up $3 exited $rc"; }
    cat "$tmp/warm.err"
    grep -q "stereo processed $4, dropped 0, missing from the log 0" "$tmp/warm.err" || fail "--warm-up $3: range counts"
    grep -q -- "$5" "$tmp/warm.err" || fail "--warm-up $3: no '$5'"
}
expect_warm_up "$tmp/gap.log" 3:6 3 4 "warm-up 3: the last 3 handed over, 3 fed to the estimator, 1 pairs computed and not written"
expect_warm_up "$tmp/nocal.log" 2:7 2 6 "warm-up 2: the last 2 handed over, 0 fed to the estimator, 0 pairs computed and not written"
# Garbage appended to a good log (a torn write): every frame still processed, exit 0.
cp "$tmp/in.log" "$tmp/torn.log" && head -c 1000 /dev/urandom >>"$tmp/torn.log"
"$LIDARFLOW_BRIDGE" --replay "$tmp/torn.log" --out "$tmp/torn_out.log" "${opts[@]}" 2>"$tmp/torn.err" \
    || { rc=$?; cat "$tmp/torn.err"; fail "replay of a torn log exited $rc"; }
"$LIDARFLOW_BRIDGE" --replay "$tmp/missing.log" --out "$tmp/x.log" 2>/dev/null && fail "missing input accepted"
echo "replay_log: ok"
