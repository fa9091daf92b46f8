#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The bridge's udpm receive buffer, inside a private network namespace (private_netns.sh): on a
# start with the README's URL (recv_buf_size=16777216) and on a default start (no --lcm-url),
# LCM prints no warning, the socket gets min(16 MiB, net.core.rmem_max) (the kernel reports
# twice that), and the bridge's own note on raising the limit appears once exactly when
# net.core.rmem_max is below 16 MiB.
set -uo pipefail
: "${LIDARFLOW_BRIDGE:?}" "${LIDARFLOW_TEST_TMP:?}"
for tool in unshare ip ss; do
    command -v "$tool" >/dev/null || { echo "skipped: $tool not installed (util-linux, iproute2)"; exit 77; }
done
. "$(dirname "${BASH_SOURCE[0]}")/private_netns.sh"
private_netns "$0" "$@"

tmp="$LIDARFLOW_TEST_TMP/bridge_recv_buffer"
rm -rf "$tmp" && mkdir -p "$tmp"
rmem_max="$(cat /proc/sys/net/core/rmem_max)"
want=16777216
granted=$((rmem_max < want ? rmem_max : want))
echo "net.core.rmem_max $rmem_max: expecting SO_RCVBUF $((2 * granted))"
fail=0
for start in readme default; do
    args=(); [ "$start" = readme ] && args=(--lcm-url "$url")
    LCM_DEFAULT_URL= "$LIDARFLOW_BRIDGE" "${args[@]}" --option threads=1 2>"$tmp/$start.err" &
    bridge=$!
    rb=""
    # The receive socket is the one bound to the udpm port (7667 in both URLs); the bridge's
    # send socket keeps the default size. It exists once the bridge has subscribed.
    for _ in $(seq 100); do
        if grep -q "listening on" "$tmp/$start.err"; then
            rb="$(ss -H -uamp 'sport = :7667' | grep -A1 "pid=$bridge," | grep -o 'rb[0-9]*' | head -1)"
            [ -n "$rb" ] && break
        fi
        sleep 0.1
    done
    kill -INT "$bridge"; wait "$bridge"; rc=$?
    echo "$start start: socket ${rb:-not found}, exit $rc"
    [ "$rc" = 0 ] || { echo "$start: bridge exited with $rc"; fail=1; }
    [ "$rb" = "rb$((2 * granted))" ] || { echo "$start: receive buffer ${rb:-not found}, expected rb$((2 * granted))"; fail=1; }
    if grep -q "is smaller than\|multicast_setup" "$tmp/$start.err"; then
        echo "$start: LCM's receive buffer warning:"; cat "$tmp/$start.err"; fail=1
    fi
    notes="$(grep -c "sysctl -w net.core.rmem_max=$want" "$tmp/$start.err")"
    expected_notes=$((rmem_max < want ? 1 : 0))
    [ "$notes" = "$expected_notes" ] || { echo "$start: $notes notes on raising the limit, expected $expected_notes:"; cat "$tmp/$start.err"; fail=1; }
done
exit "$fail"
