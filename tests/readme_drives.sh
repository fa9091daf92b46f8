#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The README's "Recorded drives and many logs" block. Written for an installed lidarflow; run
# here from the build tree as the README says to (`lidarflow` -> BUILD/tools/lidarflow/lidarflow,
# LIDARFLOW_BIN_DIR=BUILD PYTHONPATH=bindings/python before /usr/bin/python3), from the
# repository root. tests/consumer/deb_system.sh runs it verbatim on the installed .debs.
# Passes when every command succeeds and lidarflow_dask wrote the pairs `lidarflow sequence`
# wrote (its first two chunks' byte for byte) and they score alike.
#   readme_drives.sh REPO_ROOT BUILD_DIR       run it from the build tree
#   readme_drives.sh --check-installed README  run it as written (an installed lidarflow)
set -euo pipefail
fail() { echo "FAIL: $*"; exit 1; }
installed=0
if [ "${1:-}" = "--check-installed" ]; then installed=1; readme="${2:?README}"; tmp="$(mktemp -d)"
else
    repo="${1:?repository root}" build="${2:?build folder}" readme="$1/README.md"
    : "${LIDARFLOW_TEST_TMP:?}"
    tmp="$LIDARFLOW_TEST_TMP/readme_drives"
    rm -rf "$tmp" && mkdir -p "$tmp"
fi
awk '/^## Recorded drives and many logs/ { on = 1; next } /^## / { on = 0 } on && /^```sh$/ { code = 1; next }
     code && /^```$/ { code = 0; next } code' "$readme" >"$tmp/block.sh"
grep -q '^lidarflow sequence ' "$tmp/block.sh" && grep -q '^/usr/bin/python3 -m lidarflow_dask ' "$tmp/block.sh" ||
    fail "the README's block no longer runs lidarflow sequence and /usr/bin/python3 -m lidarflow_dask"
if [ "$installed" = 0 ]; then
    sed -i "s#^lidarflow #$build/tools/lidarflow/lidarflow #; s#^/usr/bin/python3 #LIDARFLOW_BIN_DIR=$build PYTHONPATH=bindings/python /usr/bin/python3 #" \
        "$tmp/block.sh"
    cd "$repo"
fi
rm -rf /tmp/drive /tmp/drive-flow /tmp/dask-out
PYTHONDONTWRITEBYTECODE=1 bash -e "$tmp/block.sh" >"$tmp/out.txt" 2>&1 || { cat "$tmp/out.txt"; fail "a command failed"; }
# The first two chunks (pairs 0..5 of --chunk 4) are the same stream as sequence's: the first
# starts where it starts, the second warms up from frame 0 (lidarflow_dask --warm-up 3). Later
# chunks warm up from later frames, so their motion priors differ a little: each pair must be
# there, and both runs must score alike against the drive's truth.
n=0
for f in /tmp/drive-flow/flow/*.png; do
    k=$((10#$(basename "$f" .png)))
    [ -f "/tmp/dask-out/drive/flow/$(basename "$f")" ] || fail "lidarflow_dask wrote no $(basename "$f")"
    [ "$k" -ge 6 ] || cmp "$f" "/tmp/dask-out/drive/flow/$(basename "$f")" || fail "$f differs from lidarflow_dask's"
    n=$((n + 1))
done
[ "$n" -eq 9 ] || fail "$n pairs, expected 9"
lf="lidarflow"; [ "$installed" = 1 ] || lf="$build/tools/lidarflow/lidarflow"
score() {  # SF outliers (occ, pooled) of result folder $1 against /tmp/drive/gt
    local est="$tmp/score-est" gt="$tmp/score-gt"
    rm -rf "$est" "$gt" && mkdir -p "$est"/{disp_0,disp_1,flow} "$gt"/{disp_occ_0,disp_occ_1,flow_occ}
    for f in "$1"/flow/*.png; do
        local b id; b="$(basename "$f" .png)"; id="$(printf %06d $((10#$b)))_10.png"
        for d in disp_0 disp_1 flow; do cp "$1/$d/$b.png" "$est/$d/$id"; done
        for d in disp_occ_0 disp_occ_1 flow_occ; do cp "/tmp/drive/gt/$d/$b.png" "$gt/$d/$id"; done
    done
    "$lf" eval --root "$gt" --est "$est" | awk '$1 == "pooled" && $2 == "occ" { print $6 }'
}
a="$(score /tmp/drive-flow)" b="$(score /tmp/dask-out/drive)"
awk -v a="$a" -v b="$b" 'BEGIN { d = a - b; exit !(a != "" && b != "" && d < 1.0 && d > -1.0) }' ||
    fail "SF outliers: lidarflow sequence $a %, lidarflow_dask $b %"
rm -rf /tmp/drive /tmp/drive-flow /tmp/dask-out "$tmp/score-est" "$tmp/score-gt"
echo "readme_drives: every command of the block ran; lidarflow_dask wrote the same $n pairs as lidarflow sequence" \
     "(the first two chunks' byte for byte; SF outliers $a % and $b %)"
