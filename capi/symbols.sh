#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# liblidarflow0's Debian symbols file and its check against the library.
#
#   capi/symbols.sh check LIB        every lf_* function LIB exports is listed in
#                                    capi/lidarflow.symbols and every listed one is exported
#                                    (exit 1 naming the difference)
#   capi/symbols.sh debian OUT ABI   writes the Debian symbols file for liblidarflow.so.ABI
#                                    (package liblidarflowABI, version node LIDARFLOW_ABI) to OUT
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
list="$root/capi/lidarflow.symbols"
listed() { grep -v '^#' "$list" | awk 'NF { print $1 }' | sort; }
case "${1:-}" in
check)
    lib="${2:?library}"
    [ -f "$lib" ] || { echo "symbols.sh: no library at $lib"; exit 1; }
    exported="$(nm -D --defined-only "$lib" | awk '$2 == "T" { sub(/@.*/, "", $3); print $3 }' | grep '^lf_' | sort)"
    missing="$(comm -23 <(echo "$exported") <(listed))"
    gone="$(comm -13 <(echo "$exported") <(listed))"
    [ -z "$missing" ] || { echo "symbols.sh: exported but not in capi/lidarflow.symbols (add them with the version that releases them):"; echo "$missing"; }
    [ -z "$gone" ] || { echo "symbols.sh: in capi/lidarflow.symbols but not exported (an incompatible change):"; echo "$gone"; }
    [ -z "$missing$gone" ] || exit 1
    echo "symbols.sh: the $(echo "$exported" | wc -l) exported functions are those of capi/lidarflow.symbols"
    ;;
debian)
    out="${2:?output file}" abi="${3:?ABI major}"
    {
        echo "liblidarflow.so.$abi liblidarflow$abi #MINVER#"
        echo "* Build-Depends-Package: liblidarflow-dev"
        grep -v '^#' "$list" | awk -v n="LIDARFLOW_$abi" 'NF { printf " %s@%s %s\n", $1, n, $2 }'
    } >"$out"
    ;;
*)
    awk 'NR > 1 && /^#/ { if (!/SPDX-License-Identifier/) print; next } NR > 1 { exit }' "$0"; exit 2 ;;
esac
