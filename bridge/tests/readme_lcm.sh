#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The LCM walkthrough, run as a user types it: every ```sh block of the README's "Running on
# LCM" and then of docs/LCM.md's "Try it" (which goes on with the README's variables), in order,
# in one bash, from the repository root, with only the line K=/path/to/...
# replaced by $LIDARFLOW_KITTI_DIR (skipped without) and the build step left out (the test runs
# on the tree ctest was built from; rebuilding under a running ctest would relink the programs
# in use). Inside a private network namespace (the blocks use udpm). Passes when every command
# succeeds and each live bridge reports every frame processed at the walkthrough's rate
# (nothing stale), with its results. About 2 minutes (the walkthrough's real-time rate).
#   readme_lcm.sh REPO_ROOT
set -uo pipefail
skip() { echo "skipped: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }
repo="${1:?repository root}"
: "${LIDARFLOW_TEST_TMP:?}"
[ -n "${LIDARFLOW_KITTI_DIR:-}" ] && [ -d "${LIDARFLOW_KITTI_DIR:-}/velodyne" ] || skip "LIDARFLOW_KITTI_DIR not set"
for tool in unshare ip lcm-logger lcm-logplayer; do
    command -v "$tool" >/dev/null || skip "$tool not installed (util-linux, iproute2, liblcm-bin)"
done
. "$(dirname "${BASH_SOURCE[0]}")/private_netns.sh"
private_netns "$0" "$@"

tmp="$LIDARFLOW_TEST_TMP/bridge_readme_lcm"
rm -rf "$tmp" && mkdir -p "$tmp"
# blocks FILE HEADING: the ```sh blocks of FILE's section HEADING (up to the next heading of the
# same or a higher level).
blocks() {
    awk -v heading="$2" '$0 == heading { on = 1; level = index($0, " "); next }
         on && /^#+ / && index($0, " ") <= level { on = 0 }
         on && /^```sh$/ { code = 1; next } code && /^```$/ { code = 0; next } code' "$1"
}
{ blocks "$repo/README.md" "## Running on LCM"; blocks "$repo/docs/LCM.md" "### Try it"; } >"$tmp/walkthrough.sh"
grep -q 'shard' "$tmp/walkthrough.sh" || fail "docs/LCM.md's Try it section has no blocks"
grep -q '^K=/path/to/kitti/training$' "$tmp/walkthrough.sh" || fail "the walkthrough no longer sets K=/path/to/kitti/training"
sed -i "s|^K=/path/to/kitti/training\$|K='$LIDARFLOW_KITTI_DIR'|" "$tmp/walkthrough.sh"
grep -q '^tools/dev.sh build$' "$tmp/walkthrough.sh" || fail "the walkthrough no longer starts with tools/dev.sh build"
sed -i '/^tools\/dev.sh build$/d' "$tmp/walkthrough.sh"
# Fail on the first command that fails, as a careful user would stop there.
# A python3 without numpy first on PATH, as pyenv's is on many machines: the walkthrough must
# name Debian's /usr/bin/python3 where it needs numpy.
mkdir -p "$tmp/other-python"
printf '#!/bin/sh\necho "python3 without numpy: ModuleNotFoundError: No module named numpy" >&2\nexit 1\n' \
    > "$tmp/other-python/python3"
chmod +x "$tmp/other-python/python3"
(cd "$repo" && PATH="$tmp/other-python:$PATH" bash -e "$tmp/walkthrough.sh") >"$tmp/out.txt" 2>&1 || { cat "$tmp/out.txt"; fail "a command failed"; }
grep -v "receive buffer\|multicast_setup\|^\s*$\|is smaller than\|WARNING\|^Summary: " "$tmp/out.txt"
# The live runs at the walkthrough's rate: each bridge (and shard) received the 4 frames and dropped none.
stops=$(grep -c "stopped. stereo received 4, processed 4, dropped 0" "$tmp/out.txt")
shards=$(grep -c "stopped. stereo received 4, processed [0-9], dropped 0 .*skipped for other shards [0-9]" "$tmp/out.txt")
[ "$stops" -ge 4 ] || fail "$stops live bridge(s) processed every frame, expected 4 (the first three and the recorded run)"
[ "$shards" -ge 3 ] || fail "$shards shard(s) kept every frame, expected 3"
grep -q "shards dead 0" "$tmp/out.txt" || fail "a shard was taken for dead"
grep -q "replayed /tmp/in.log -> /tmp/out.log .* stereo processed 4, dropped 0" "$tmp/out.txt" || fail "offline replay"
echo "readme_lcm: every command of the walkthrough ran"
