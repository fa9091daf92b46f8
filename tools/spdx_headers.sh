#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Gives every tracked source file an SPDX licence line (LICENSE: MIT) in its own comment
# syntax, after a shebang when there is one. Idempotent: files whose first lines already carry
# an SPDX-License-Identifier are left alone, so it can be re-run after merging other branches.
#   tools/spdx_headers.sh           add the missing lines
#   tools/spdx_headers.sh --check   list files without one; exit 1 if any (the spdx_headers test)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if ! git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    echo "spdx_headers: not a git checkout (the file list comes from git ls-files)"; exit 77
fi
check=0
[ "${1:-}" = "--check" ] && check=1
id="SPDX-License-Identifier: MIT"

# The comment line for a file, or nothing for files that take no header (data, docs, licence).
header_for() {
    case "${1##*/}" in
        *.c|*.h|*.h.in|*.map) echo "/* $id */" ;;
        *.cpp|*.hpp|*.inl|*.lcm) echo "// $id" ;;
        *.py|*.sh|*.cmake|*.cmake.in|*.pc.in|CMakeLists.txt) echo "# $id" ;;
        *.*) ;;
        *) head -c 2 "$1" | grep -q '^#!' && echo "# $id" ;;
    esac
    return 0
}

missing=0
# git ls-files: tracked files only, never build trees or data; -z for any file name.
while IFS= read -r -d '' f; do
    [ -f "$f" ] && [ ! -L "$f" ] || continue
    line="$(header_for "$f")"
    [ -n "$line" ] || continue
    head -n 5 "$f" | grep -q "SPDX-License-Identifier:" && continue
    if [ $check -eq 1 ]; then
        echo "no SPDX line: $f"; missing=1; continue
    fi
    tmp="$(mktemp)"
    if head -c 2 "$f" | grep -q '^#!'; then
        { head -n 1 "$f"; echo "$line"; tail -n +2 "$f"; } > "$tmp"
    else
        { echo "$line"; cat "$f"; } > "$tmp"
    fi
    cat "$tmp" > "$f"  # keeps the file's mode (scripts stay executable)
    rm -f "$tmp"
    echo "added: $f"
done < <(git ls-files -z)
exit $missing
