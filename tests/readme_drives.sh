#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The README's "Recorded drives and many logs" block, run as a user types it, from the repository
# root, with only `build` replaced by the tree ctest was built from. Passes when every command
# succeeds and lidarflow_dask wrote the pairs `lidarflow sequence` wrote, byte for byte.
#   readme_drives.sh REPO_ROOT BUILD_DIR
set -euo pipefail
repo="${1:?repository root}" build="${2:?build folder}"
: "${LIDARFLOW_TEST_TMP:?}"
tmp="$LIDARFLOW_TEST_TMP/readme_drives"
rm -rf "$tmp" && mkdir -p "$tmp"
awk '/^## Recorded drives and many logs/ { on = 1; next } /^## / { on = 0 } on && /^```sh$/ { code = 1; next }
     code && /^```$/ { code = 0; next } code' "$repo/README.md" >"$tmp/block.sh"
grep -q 'lidarflow_dask' "$tmp/block.sh" || { echo "FAIL: the README's block has no lidarflow_dask command"; exit 1; }
sed -i "s#=build/#=$build/#g; s#LIDARFLOW_BIN_DIR=build #LIDARFLOW_BIN_DIR=$build #g" "$tmp/block.sh"
rm -rf /tmp/drive /tmp/drive-flow /tmp/dask-out
(cd "$repo" && PATH="/usr/bin:/bin:$PATH" bash -e "$tmp/block.sh") >"$tmp/out.txt" 2>&1 || { cat "$tmp/out.txt"; echo "FAIL: a command failed"; exit 1; }
n=0
for f in /tmp/drive-flow/flow/*.png; do
    cmp "$f" "/tmp/dask-out/drive/flow/$(basename "$f")" || { echo "FAIL: $f differs from lidarflow_dask's"; exit 1; }
    n=$((n + 1))
done
[ "$n" -eq 9 ] || { echo "FAIL: $n pairs, expected 9"; exit 1; }
rm -rf /tmp/drive /tmp/drive-flow /tmp/dask-out
echo "readme_drives: every command of the block ran; lidarflow_dask wrote the same $n pairs as lidarflow sequence"
