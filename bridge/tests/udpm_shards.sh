#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# --shard K/N over udpm://: N bridge processes share one stream, in a private network namespace
# (unshare -n, loopback only; skipped where not permitted). The stream is a single 30-frame
# sequence of bot_core.images_t + pointcloud_t (make_bot_core_log, played by lcm-logplayer),
# recorded by lcm-logger with every shard's results and status. Passes when each of the 29
# pairs is published exactly once overall, no shard dropped a frame (nothing stale), every
# shard's last status accounts for all 30 frames (processed + skipped for other shards), and
# sampled results equal the C ABI's.
# With "kill", shard 1 is killed (SIGKILL) a third into the stream: the others must take it for
# dead (no status for 3 s) and the first live shard after it (2) count its pairs without a result
# as lost: pairs published + pairs_lost_dead_shard = 29 exactly.
#   udpm_shards.sh [N [SPEED [QUEUE [kill]]]]  N shards (default 3); lcm-logplayer speed (default 0.3:
#                  the 10 Hz log at 3 Hz, about twice what one process sustains here, see
#                  docs/LCM.md); queue per shard (default 32: this test checks the sharding,
#                  not the CPU of a shared machine). Prints the throughput: pairs per second
#                  from the first frame's to the last result's arrival at the logger.
set -uo pipefail
shards="${1:-3}" speed="${2:-0.3}" queue="${3:-32}" kill="${4:-}"
frames=30
skip() { echo "skipped: $*"; exit 77; }
: "${LIDARFLOW_BRIDGE:?}" "${LIDARFLOW_LOG_CHECK:?}" "${LIDARFLOW_MAKE_BOT_CORE_LOG:?}" "${LIDARFLOW_TEST_TMP:?}"
for tool in unshare ip lcm-logger lcm-logplayer; do
    command -v "$tool" >/dev/null || skip "$tool not installed (util-linux, iproute2, liblcm-bin)"
done
. "$(dirname "${BASH_SOURCE[0]}")/private_netns.sh"
private_netns "$0" "$@"

tmp="$LIDARFLOW_TEST_TMP/bridge_udpm_shards_$shards$kill"
rm -rf "$tmp" && mkdir -p "$tmp"
l2c=$("$LIDARFLOW_MAKE_BOT_CORE_LOG" "$tmp/in.log" "$tmp" "$frames") || exit 1
inputs=(--stereo-channel STEREO_CAMERA --lidar-channel VELODYNE_POINTS --calib "$tmp/calib_cam_to_cam.txt"
        --lidar-to-camera "$l2c")
opts=(--option matching.min_coarsest_height=16 --option threads=1)

pids=()
cleanup() { for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null; done; }
trap cleanup EXIT
lcm-logger --lcm-url="$url" -q "$tmp/run.log" 2>"$tmp/logger.err" &
logger=$!; pids+=("$logger")
bridges=()
for ((k = 0; k < shards; ++k)); do
    "$LIDARFLOW_BRIDGE" --lcm-url "$url" --shard "$k/$shards" --queue "$queue" --status-period 1 --verbose \
        "${inputs[@]}" "${opts[@]}" 2>"$tmp/bridge$k.err" &
    bridges+=($!); pids+=($!)
done
# Every shard must be subscribed before the first frame: with no frame counter in images_t,
# the shards index frames by arrival, so all must see the same frames.
for ((i = 0; i < 300; ++i)); do
    [ "$(cat "$tmp"/bridge*.err | grep -c "listening on")" -ge "$shards" ] && break
    sleep 0.1
done
sleep 0.3
lcm-logplayer --lcm-url="$url" -s "$speed" "$tmp/in.log" >"$tmp/player.out" 2>&1 &
player=$!
if [ -n "$kill" ]; then
    sleep "$(awk -v s="$speed" -v n="$frames" 'BEGIN { print n / 10 / s / 3 }')"
    kill -KILL "${bridges[1]}"; wait "${bridges[1]}" 2>/dev/null
    echo "killed shard 1"
fi
wait "$player" || { cat "$tmp/player.out"; exit 1; }
# Wait for the pairs still in the shards' queues (each logs a line per published result) and,
# with a dead shard, for its pairs to be counted as lost (a line per declaration with the pairs
# pending then, and with --verbose one per later pair).
pairs=$((frames - 1))
accounted() {
    local published lost
    published=$(cat "$tmp"/bridge*.err | grep -c "published scene flow")
    lost=$(cat "$tmp"/bridge*.err | sed -n 's/.*counted here as lost: \([0-9]*\) pair.*/\1/p; s/.*lost: its shard .* is dead/1/p' |
           awk '{ n += $1 } END { print n + 0 }')
    [ $((published + lost)) -ge "$pairs" ]
}
for ((i = 0; i < 450; ++i)); do
    accounted && break
    sleep 0.1
done
rc=0
for ((k = 0; k < shards; ++k)); do
    [ -n "$kill" ] && [ "$k" = 1 ] && continue
    kill -INT "${bridges[k]}"; wait "${bridges[k]}" || rc=1
done
sleep 0.3
kill -INT "$logger"; wait "$logger"
grep -hv "receive buffer\|multicast_setup\|^\s*$\|is smaller than\|published scene flow" "$tmp"/bridge*.err
[ "$rc" = 0 ] || { echo "a bridge exited non-zero"; exit 1; }
"$LIDARFLOW_LOG_CHECK" throughput "$tmp/run.log" --stereo-channel STEREO_CAMERA
dead=(); [ -n "$kill" ] && dead=(--dead-shard 1)
"$LIDARFLOW_LOG_CHECK" verify "$tmp/run.log" "${inputs[@]}" "${opts[@]}" --expect-pairs "$pairs" --check-every 7 \
    --min-results 1 "${dead[@]}"
