#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The README's "Recorded drives and many logs" block. Written for an installed lidarflow; run
# here from the build tree as the README says to (`lidarflow` -> BUILD/tools/lidarflow/lidarflow,
# LIDARFLOW_BIN_DIR=BUILD PYTHONPATH=bindings/python before /usr/bin/python3), from the
# repository root. tests/consumer/deb_system.sh runs it verbatim on the installed .debs.
# Passes when every command succeeds and lidarflow_dask wrote, byte for byte, the pairs
# `lidarflow sequence` wrote.
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
n=0
for f in /tmp/drive-flow/flow/*.png; do
    cmp "$f" "/tmp/dask-out/drive/flow/$(basename "$f")" || fail "$f differs from lidarflow_dask's"
    n=$((n + 1))
done
[ "$n" -eq 9 ] || fail "$n pairs, expected 9"
rm -rf /tmp/drive /tmp/drive-flow /tmp/dask-out
echo "readme_drives: every command of the block ran; lidarflow_dask wrote the same $n pairs as lidarflow sequence"
