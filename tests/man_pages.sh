#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The man pages help2man made from the programs' --help: man renders them without a warning
# (lintian's check: manpage-has-errors-from-man), and they hold what the --help texts say
# (every lidarflow command, the options, the exit statuses).
# Usage: man_pages.sh MAN_DIR LIDARFLOW_CLI [LIDARFLOW_BRIDGE]
set -euo pipefail
dir="$1" cli="$2" bridge="${3:-}"
fail() { echo "FAIL: $*"; exit 1; }

# render PAGE: the page as man shows it; fails on any warning of groff or man.
render() {
    local page="$1" warnings
    [ -s "$page" ] || fail "$page missing"
    warnings="$(LC_ALL=C.UTF-8 MANWIDTH=100 man --warnings -E UTF-8 -l -Tutf8 -Z "$page" 2>&1 >/dev/null)"
    [ -z "$warnings" ] || fail "$page: man warns: $warnings"
    LC_ALL=C.UTF-8 MANWIDTH=100 man -E ascii -l "$page" 2>/dev/null | col -b
}
# has TEXT NEEDLE...: each needle is in the text.
has() {
    local text="$1"; shift
    for n in "$@"; do grep -qF -- "$n" <<<"$text" || fail "man page lacks '$n'"; done
}

page="$(render "$dir/lidarflow.1.gz")"
has "$page" "LIDARFLOW(1)" "$("$cli" --version)" "--verbose" "exit status" "sequence: some pairs lost to bad frames"
# Every command of `lidarflow --help`.
commands="$("$cli" --help | awk '/^commands:/ { on = 1; next } on && /^$/ { exit } on { print $1 }')"
[ "$(wc -l <<<"$commands")" -ge 8 ] || fail "no command list in lidarflow --help"
for c in $commands; do has "$page" "$c"; done

if [ -n "$bridge" ]; then
    page="$(render "$dir/lidarflow-lcm-bridge.1.gz")"
    has "$page" "LIDARFLOW-LCM-BRIDGE(1)" "--replay" "--frames A:B" "--warm-up N" "--shard K/N" "Exit status" "a bad command line"
fi
echo "man pages: ok"
