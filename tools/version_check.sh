#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# One version everywhere: `lidarflow --version`, the library's lf_version_string (the CLI prints
# it), the Python package (bindings/python/pyproject.toml) and the newest release heading of
# CHANGELOG.md ("## [X.Y.Z] - date"), and the SONAME's major is LIDARFLOW_ABI_MAJOR.
#   tools/version_check.sh LIDARFLOW_CLI LIBLIDARFLOW_SO
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cli="${1:?lidarflow CLI}" lib="${2:?liblidarflow.so}"
fail() { echo "version_check: $*"; exit 1; }
cli_version="$("$cli" --version | awk '{ print $2 }')"
py_version="$(awk -F'"' '/^version = / { print $2; exit }' "$root/bindings/python/pyproject.toml")"
log_version="$(awk '/^## \[[0-9]+\.[0-9]+\.[0-9]+\]/ { v = $2; gsub(/[][]/, "", v); print v; exit }' "$root/CHANGELOG.md")"
abi_major="$(awk '/set\(LIDARFLOW_ABI_MAJOR/ { gsub(/[^0-9]/, "", $2); print $2; exit }' "$root/CMakeLists.txt")"
soname="$(objdump -p "$lib" | awk '$1 == "SONAME" { print $2 }')"
[ "$py_version" = "$cli_version" ] || fail "pyproject.toml says $py_version, lidarflow --version $cli_version"
[ "$log_version" = "$cli_version" ] || fail "CHANGELOG.md's newest release is $log_version, lidarflow --version $cli_version"
[ "$soname" = "liblidarflow.so.$abi_major" ] || fail "SONAME $soname, LIDARFLOW_ABI_MAJOR $abi_major"
echo "version_check: $cli_version everywhere; SONAME $soname"
