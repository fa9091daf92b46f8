#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Multi-Arch fields of the Debian packages deb_consumers built (cmake/debian/multiarch.cmake
# writes them after CPack): liblidarflow0 and liblidarflow-dev `same`, lidarflow-tools
# `foreign`, the arch-all packages none. A `same` package is co-installed for several
# architectures only when the files they share are the same bytes, so each file of one outside
# the multiarch libdir must be an architecture-independent one (headers, copyright, changelog),
# and its changelog.Debian.gz must not carry the build's time: gzip without name or time stamp,
# dated by CHANGELOG.md's release date. The packages are rebuilt with owners root, as CPack's.
# Usage: deb_control.sh PACKAGES_DIR SOURCE_DIR
set -euo pipefail
dir="$1" src="$2"
command -v dpkg-deb >/dev/null || { echo "deb control check skipped: no dpkg-deb"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }
multiarch="$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || gcc -print-multiarch)"
declare -A expected=([liblidarflow0]=same [liblidarflow-dev]=same [lidarflow-tools]=foreign
                     [lidarflow-lcm-types]="" [python3-lidarflow]="" [python3-lidarflow-dask]="")
shopt -s nullglob
debs=("$dir"/*.deb)
[ ${#debs[@]} -ge 5 ] || fail "expected the packages in $dir, found ${#debs[@]}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
seen=0
for deb in "${debs[@]}"; do
    pkg="$(dpkg-deb -f "$deb" Package)"
    arch="$(dpkg-deb -f "$deb" Architecture)"
    # From the control file itself: dpkg-deb -f prints "no" for an absent field.
    ma="$(dpkg-deb -I "$deb" control | sed -n 's/^Multi-Arch: *//p')"
    [ -n "${expected[$pkg]+set}" ] || fail "$pkg: a package this check does not know: decide its Multi-Arch here"
    [ "$ma" = "${expected[$pkg]}" ] || fail "$pkg: Multi-Arch '$ma', expected '${expected[$pkg]}'"
    [ "$arch" != all ] || [ -z "$ma" ] || fail "$pkg: Architecture all with Multi-Arch $ma"
    echo "$pkg ($arch): Multi-Arch: ${ma:-(none)}"
    seen=$((seen + 1))
    # Owners as CPack gives them (the rebuilt packages too).
    owners="$(dpkg-deb -c "$deb" | awk '$2 != "root/root"')"
    [ -z "$owners" ] || fail "$pkg: entries not owned by root: $owners"
    [ "$ma" = same ] || continue
    # Files outside the multiarch libdir are shared between the architectures' instances.
    while read -r path; do
        case "$path" in
            ./usr/lib/"$multiarch"/*) ;;
            ./usr/include/lidarflow/*.h | ./usr/include/lidarflow/*.hpp) ;;
            ./usr/share/doc/"$pkg"/copyright | ./usr/share/doc/"$pkg"/changelog.Debian.gz) ;;
            *) fail "$pkg (Multi-Arch: same): $path is outside usr/lib/$multiarch and not known to be the same on every architecture" ;;
        esac
    done < <(dpkg-deb -c "$deb" | awk '$1 !~ /^d/ { print $6 }')
    rm -rf "$work/x"
    dpkg-deb -x "$deb" "$work/x"
    log="$work/x/usr/share/doc/$pkg/changelog.Debian.gz"
    [ -f "$log" ] || fail "$pkg: no changelog.Debian.gz"
    # gzip header: byte 3 the flags (8 = a file name follows), bytes 4-7 the time stamp.
    header="$(od -An -tu1 -j3 -N5 "$log" | tr -s ' ' | sed 's/^ //')"
    [ "$header" = "0 0 0 0 0" ] || fail "$pkg: changelog.Debian.gz has a file name or time stamp (gzip header: $header)"
    version="$(dpkg-deb -f "$deb" Version)"
    upstream="${version%-*}"
    released="$(sed -n "s/^## \[${upstream//./\\.}\] - \([0-9-]*\)$/\1/p" "$src/CHANGELOG.md")"
    [ -n "$released" ] || fail "CHANGELOG.md has no release heading for $upstream"
    want="$(LC_ALL=C date -u -d "$released" '+%a, %d %b %Y 00:00:00 +0000')"
    gunzip -c "$log" | grep -qF -- "  $want" || fail "$pkg: changelog.Debian.gz is not dated $want: $(gunzip -c "$log" | tail -1)"
done
[ "$seen" -eq "${#debs[@]}" ] || fail "not every package checked"
echo "deb control: ok"
