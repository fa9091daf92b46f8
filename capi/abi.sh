#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The committed ABI description of liblidarflow.so (capi/lidarflow.abi.xml) and its check.
#
#   capi/abi.sh check   LIB   dump LIB's ABI and compare it with the committed description:
#                             fails (exit 1) on an incompatible change (abidiff bit 3) or an
#                             abidiff error; a compatible change (e.g. a new function) passes
#                             with a note to refresh.
#   capi/abi.sh refresh LIB   overwrite capi/lidarflow.abi.xml with LIB's ABI. Do this
#                             deliberately, after a compatible addition, or together with a
#                             bump of LIDARFLOW_ABI_MAJOR (CMakeLists.txt) and of the version
#                             node in capi/lidarflow.map after an incompatible change.
#
# LIB is the built liblidarflow.so (e.g. build/capi/liblidarflow.so); it carries debug info
# for the C ABI's own translation units (capi/CMakeLists.txt adds -g there). Only the types of
# the public header reach the description (--headers-dir, --drop-private-types), and nothing
# that depends on the build machine (no paths, no DT_NEEDED list, hashed type ids).
set -euo pipefail
mode="${1:-}"; lib="${2:-}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
committed="$root/capi/lidarflow.abi.xml"
if [ -z "$lib" ] || { [ "$mode" != check ] && [ "$mode" != refresh ]; }; then
    # The header comment, after the shebang, without the SPDX line.
    awk 'NR > 1 && /^#/ { if (!/SPDX-License-Identifier/) print; next } NR > 1 { exit }' "$0" | head -n 12; exit 2
fi
for tool in abidw abidiff; do
    command -v "$tool" >/dev/null || { echo "abi.sh: $tool not found (Debian abigail-tools; tools/dev.sh deps)"; exit 1; }
done
[ -f "$lib" ] || { echo "abi.sh: no library at $lib"; exit 1; }

dump() {  # dump OUT
    abidw --headers-dir "$root/include/lidarflow" --drop-private-types --exported-interfaces-only \
          --no-elf-needed --no-corpus-path --no-comp-dir-path --no-show-locs --drop-undefined-syms \
          --type-id-style hash --out-file "$1" "$lib"
    # Translation-unit paths are the checkout's: keep them relative to the repository.
    sed -i "s|path='$root/|path='|g" "$1"
}

if [ "$mode" = refresh ]; then
    dump "$committed"
    echo "abi.sh: wrote $committed ($(grep -c '<function-decl' "$committed") functions)"
    exit 0
fi

tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
dump "$tmp/current.abi.xml"
# abidiff exit bits: 1 error, 2 usage error, 4 ABI change, 8 incompatible change. It sets 8 only
# where incompatibility is certain (a removed function); a changed struct layout or parameter
# type is "only" 4, yet breaks every old binary that uses it. So: judge the existing interfaces
# (--no-added-syms) and fail on any change there; added functions alone pass.
abidiff_rc() {  # abidiff_rc REPORT [options]: abidiff's exit status, report in REPORT
    local report="$1"; shift
    set +e
    abidiff "$@" "$committed" "$tmp/current.abi.xml" > "$report" 2>&1
    local rc=$?
    set -e
    if [ $((rc & 3)) -ne 0 ]; then cat "$report"; echo "abi.sh: abidiff failed (exit $rc)"; exit 1; fi
    return $rc
}
rc=0; abidiff_rc "$tmp/existing.txt" --no-added-syms || rc=$?
if [ $((rc & 8)) -ne 0 ]; then
    cat "$tmp/existing.txt"
    echo "abi.sh: INCOMPATIBLE change of the C ABI against capi/lidarflow.abi.xml (removed or"
    echo "        changed interface). Undo it, or bump LIDARFLOW_ABI_MAJOR and refresh:"
    echo "        capi/abi.sh refresh $lib"
    exit 1
fi
if [ $((rc & 4)) -ne 0 ]; then
    cat "$tmp/existing.txt"
    echo "abi.sh: an existing interface of the C ABI changed (type layout, parameters): old"
    echo "        binaries break. Undo it; only if the change is compatible by design (a field"
    echo "        appended to a struct that starts with struct_size) record it deliberately:"
    echo "        capi/abi.sh refresh $lib"
    exit 1
fi
rc=0; abidiff_rc "$tmp/all.txt" || rc=$?
if [ $((rc & 4)) -ne 0 ]; then
    cat "$tmp/all.txt"
    echo "abi.sh: compatible additions; record them with: capi/abi.sh refresh $lib"
fi
echo "abi.sh: ABI compatible with capi/lidarflow.abi.xml"
