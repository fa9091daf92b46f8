#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# lidarflow-lcm-bridge's command line (the parser shared with the CLI): bad arguments exit 2
# with a message, a typo gets "did you mean", and every option of --help is known to the parser.
# No case reaches LCM: each fails on its arguments, or prints and exits.
set -euo pipefail
: "${LIDARFLOW_BRIDGE:?}"
failures=0

# expect RC PATTERN ARGS...: the bridge exits RC and its output matches PATTERN (grep -E).
expect() {
    local want_rc="$1" pattern="$2" out rc
    shift 2
    rc=0
    out="$("$LIDARFLOW_BRIDGE" "$@" 2>&1)" || rc=$?
    if [ "$rc" -ne "$want_rc" ] || ! grep -qE -- "$pattern" <<<"$out"; then
        echo "FAIL: lidarflow-lcm-bridge $* -> rc $rc (want $want_rc), output:"
        echo "$out"
        echo "(wanted /$pattern/)"
        failures=$((failures + 1))
    fi
}

expect 2 'unknown option --queu \(did you mean --queue\?\)' --queu 2
expect 2 'unknown option --stereo-chanel \(did you mean --stereo-channel\?\)' --stereo-chanel X
expect 2 'unknown option --banana \(see --help\)' --banana
expect 2 "unexpected argument 'stray'" stray
expect 2 'option --lcm-url needs a value' --lcm-url
expect 2 'option --verbose takes no value' --verbose=1
expect 2 '--queue expects a number in \[1, 1000\], got .0.' --queue 0
expect 2 '--step expects a number in \[1, 16\], got .17.' --step 17
expect 2 '--status-period expects a finite number, got .x.' --status-period x
expect 2 '--lidar-tolerance-ms expects a number in \[0, 1e\+06\]' --lidar-tolerance-ms -1
expect 2 '--option threads: expected KEY=VALUE' --option threads=2 --option threads
expect 2 '--option =2: expected KEY=VALUE' --option=threads=2 --option =2
expect 2 '--encoding png: expected float32 or int16' --encoding png
expect 2 '--lidar-to-camera 1,2,3: expected 16 numbers' --lidar-to-camera 1,2,3
expect 2 '--replay and --out go together' --replay in.log
expect 2 '--left-channel and --right-channel go together' --left-channel CAM_LEFT
expect 2 '--left-channel and --right-channel go together, on two different channels' --left-channel A --right-channel A
expect 2 '--replay takes stereo frames from the stereo channel only' --replay in.log --out out.log --left-channel L --right-channel R
expect 2 '--pair-wait-ms expects a number in \[0, 10000\]' --pair-wait-ms -5
expect 2 '--shard-timeout needs --shard K/N with N > 1' --shard-timeout 2
expect 2 '--shard-timeout needs --shard K/N with N > 1 and a --status-period > 0' --shard 0/2 --shard-timeout 2 --status-period 0
expect 2 '--shard-timeout expects a number in \[0, 3600\]' --shard 0/2 --shard-timeout -1
expect 2 '--replay and --out go together' --replay in.log --out out.log --lcm-url udpm://
expect 2 '--shard-key /nonexistent/key: No such file' --shard 0/2 --shard-key /nonexistent/key
short_key="$(mktemp)" && printf 'short\n' >"$short_key"
expect 2 'a shard key needs at least 16 bytes' --shard 0/2 --shard-key "$short_key"
printf '0123456789abcdef0123\n' >"$short_key"
expect 2 '--shard-key needs --shard K/N with N > 1' --shard-key "$short_key"
rm -f "$short_key"
expect 2 '--quiet and --verbose exclude each other' --quiet --verbose
expect 2 '--warm-up 3: expected a number of frames in \[0, 1000\], with --replay' --warm-up 3
expect 2 '--warm-up -1: expected a number of frames in \[0, 1000\]' --replay in.log --out out.log --frames 2:4 --warm-up -1
expect 2 '--warm-up 1001: expected a number of frames in \[0, 1000\]' --replay in.log --out out.log --warm-up 1001
expect 2 '--warm-up expects an integer, got .x.' --replay in.log --out out.log --warm-up x
expect 2 '--warm-up expects an integer, got .2.5.' --replay in.log --out out.log --warm-up 2.5
expect 2 '--warm-up expects an integer, got .99999999999.' --replay in.log --out out.log --warm-up 99999999999
expect 0 '^usage: lidarflow-lcm-bridge' --help
expect 0 '^lidarflow-lcm-bridge [0-9]' --queue 0 --version

# Every option the help names is one the parser knows (the help text and the option table are
# written apart): given without its value it is "needs a value", never "unknown option".
names="$("$LIDARFLOW_BRIDGE" --help | grep -oE -- '--[a-z][a-z0-9-]*' | sort -u)"
[ "$(wc -l <<<"$names")" -ge 20 ] || { echo "FAIL: too few options in --help: $names"; failures=$((failures + 1)); }
for name in $names; do
    case "$name" in
        --help | --version) ;;
        --verbose) expect 2 '--queue expects a number' --verbose --queue 0 ;;
        --quiet) expect 2 '--queue expects a number' --quiet --queue 0 ;;
        *) expect 2 "option $name needs a value" "$name" ;;
    esac
done

[ "$failures" -eq 0 ] || { echo "$failures case(s) failed"; exit 1; }
echo "bridge_args: all cases passed"
