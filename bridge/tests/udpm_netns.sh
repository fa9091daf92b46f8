#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The real processes over udpm://: lidarflow publish-kitti -> lidarflow-lcm-bridge, recorded by
# lcm-logger, then checked (log_check verify: every published flow equals the C ABI's result
# for the frames it names; the bridge's last status accounts for every stereo frame).
# ALWAYS inside a private network namespace made here (unshare -n): multicast stays on its own
# loopback and cannot reach a real interface. Without the permission to make one: skipped.
#   udpm_netns.sh synth   synthetic 320x96 frames at 2 Hz (fast)
#   udpm_netns.sh kitti   the KITTI frames of $LIDARFLOW_KITTI_DIR at 10 Hz (skipped without);
#                         prints the bridge's latency and drop counters; LIDARFLOW_KITTI_LOOPS=N
#                         plays the two frames N times (default 15, i.e. 60 frames in 6 s)
set -uo pipefail
mode="${1:-synth}"
skip() { echo "skipped: $*"; exit 77; }
: "${LIDARFLOW_CLI:?}" "${LIDARFLOW_BRIDGE:?}" "${LIDARFLOW_LOG_CHECK:?}" "${LIDARFLOW_TEST_TMP:?}"
if [ "$mode" = kitti ]; then
    [ -n "${LIDARFLOW_KITTI_DIR:-}" ] && [ -d "${LIDARFLOW_KITTI_DIR:-}/image_2" ] || skip "LIDARFLOW_KITTI_DIR not set"
fi
for tool in unshare ip lcm-logger; do
    command -v "$tool" >/dev/null || skip "$tool not installed (util-linux, iproute2, liblcm-bin)"
done
. "$(dirname "${BASH_SOURCE[0]}")/private_netns.sh"
private_netns "$0" "$@"

tmp="$LIDARFLOW_TEST_TMP/bridge_udpm_$mode"
rm -rf "$tmp" && mkdir -p "$tmp"
if [ "$mode" = kitti ]; then
    root="$LIDARFLOW_KITTI_DIR"; ids=000002,000003; rate=10; loops="${LIDARFLOW_KITTI_LOOPS:-15}"
    opts=(); bridge_opts=(); min_results=1
else
    "$LIDARFLOW_CLI" synth --out "$tmp/scene" --width 320 --height 96 --frames 2 >/dev/null || exit 1
    root="$tmp/scene"; ids=000000,000001; rate=2; loops=2
    opts=(--option matching.min_coarsest_height=16 --option threads=2); bridge_opts=("${opts[@]}"); min_results=2
fi

pids=()
cleanup() { for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null; done; }
trap cleanup EXIT
lcm-logger --lcm-url="$url" -q "$tmp/run.log" 2>"$tmp/logger.err" &
logger=$!; pids+=("$logger")
"$LIDARFLOW_BRIDGE" --lcm-url "$url" --status-period 0.5 "${bridge_opts[@]}" 2>"$tmp/bridge.err" &
bridge=$!; pids+=("$bridge")
sleep 0.5
"$LIDARFLOW_CLI" publish-kitti --root "$root" --ids "$ids" --lidar paper --lcm-url "$url" --rate "$rate" \
    --loop "$loops" 2>"$tmp/player.err" || { cat "$tmp/player.err"; exit 1; }
# Give the bridge time for the frame in progress (a KITTI frame takes seconds), then stop it:
# SIGINT publishes a final status (a frame still in progress is finished first, queued ones are
# counted as shutdown drops). lcm-logger flushes its log only when stopped with SIGINT.
if [ "$mode" = kitti ]; then sleep 2; else sleep 1.5; fi
kill -INT "$bridge"
wait "$bridge"; bridge_rc=$?
sleep 0.3
kill -INT "$logger"; wait "$logger"
grep -v "receive buffer\|multicast_setup\|^\s*$\|is smaller than" "$tmp/bridge.err"
[ "$bridge_rc" = 0 ] || { echo "bridge exited with $bridge_rc"; exit 1; }
"$LIDARFLOW_LOG_CHECK" verify "$tmp/run.log" "${opts[@]}" --min-results "$min_results"
