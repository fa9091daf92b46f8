#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Debian packages installed and purged with dpkg on a scratch copy of this system: an
# overlay over / (changes go to a tmpfs) in a private mount namespace, entered with chroot, so
# the maintainer scripts run as on a real install and nothing reaches the real system.
# Checks, on the installed system: pkg-config prints plain /usr paths, the Python packages were
# byte-compiled (postinst) and import, a program builds against the LCM types' .pc and CMake
# target; after `dpkg --purge python3-lidarflow` (and the python3-lidarflow-* packages that
# depend on it), nothing of the Python packages is left (no
# __pycache__) and `import lidarflow` fails cleanly; after purging all, /usr is as before.
# Needs root (mount namespace, overlayfs): skipped (77) otherwise.
#   deb_system.sh PACKAGES_DIR WORK CONSUMER_SRC
set -euo pipefail
packages="$1"; work="$2"; src="$3"

if [ -z "${LIDARFLOW_IN_SCRATCH_SYSTEM:-}" ]; then
    [ "$(id -u)" = 0 ] || { echo "skipped: needs root (a mount namespace and an overlay over /)"; exit 77; }
    command -v unshare >/dev/null && command -v chroot >/dev/null || { echo "skipped: no unshare/chroot (util-linux)"; exit 77; }
    unshare -m true 2>/dev/null || { echo "skipped: not permitted to make a mount namespace"; exit 77; }
    debs=("$packages"/*.deb)
    [ -f "${debs[0]}" ] || { echo "no packages in $packages"; exit 1; }
    rm -rf "$work"; mkdir -p "$work"
    LIDARFLOW_IN_SCRATCH_SYSTEM=1 exec unshare -m --propagation private bash "$0" "$@"
fi

# In the private mount namespace: the scratch system at $work/root.
mkdir -p "$work/layers" "$work/root"
mount -t tmpfs -o size=2g lidarflow-scratch "$work/layers"
mkdir -p "$work/layers/upper" "$work/layers/work"
mount -t overlay lidarflow-scratch -o "lowerdir=/,upperdir=$work/layers/upper,workdir=$work/layers/work" "$work/root" ||
    { echo "skipped: overlayfs over / not available"; exit 77; }
mount --rbind /dev "$work/root/dev"
mount -t proc proc "$work/root/proc"
mkdir -p "$work/root/tmp/lidarflow-debs" "$work/root/tmp/consumer"
cp "$packages"/*.deb "$work/root/tmp/lidarflow-debs/"
cp -r "$src"/. "$work/root/tmp/consumer/"
cp "$src/../../README.md" "$src/../readme_drives.sh" "$work/root/tmp/consumer/"

chroot "$work/root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LC_ALL=C.UTF-8 \
    bash -euo pipefail -s <<'SCRATCH'
fail() { echo "FAIL: $*"; exit 1; }
find /usr -path '*lidarflow*' | sort > /tmp/before.txt
dpkg -i /tmp/lidarflow-debs/*.deb > /tmp/dpkg-install.log 2>&1 || { cat /tmp/dpkg-install.log; fail "dpkg -i"; }
multiarch="$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || gcc -print-multiarch)"

# Library and pkg-config.
[ -f "/usr/lib/$multiarch/liblidarflow.so.0" ] || fail "no /usr/lib/$multiarch/liblidarflow.so.0"
flags="$(echo $(pkg-config --cflags --libs lidarflow))"  # (echo: pkgconf ends with a space)
all="$(echo $(PKG_CONFIG_ALLOW_SYSTEM_CFLAGS=1 PKG_CONFIG_ALLOW_SYSTEM_LIBS=1 pkg-config --cflags --libs lidarflow))"
echo "pkg-config --cflags --libs lidarflow: '$flags'; with system paths: '$all'"
[ "$flags" = "-llidarflow" ] && [ "$all" = "-I/usr/include -L/usr/lib/$multiarch -llidarflow" ] || fail "pkg-config not normalised"
[ "$(pkg-config --variable=csourcedir lidarflow-lcm-types)" = /usr/share/lidarflow/lcm/c ] || fail "lidarflow-lcm-types.pc"

# LCM types through the .pc file and the CMake target, as a user of the packages builds.
cd /tmp/consumer
cc -std=c99 -c "$(pkg-config --variable=csourcedir lidarflow-lcm-types)/lidarflow_status_t.c" \
   $(pkg-config --cflags lidarflow-lcm-types) -o /tmp/status.o
c++ -std=c++17 -Wall -Wextra -Werror lcm_types_consumer.cpp /tmp/status.o $(pkg-config --cflags --libs lidarflow-lcm-types) \
    -o /tmp/lcm_pc
/tmp/lcm_pc
cmake -S lcm_types -B /tmp/lcm-cmake >/dev/null && cmake --build /tmp/lcm-cmake >/dev/null || fail "CMake lidarflow::lcm_types"
/tmp/lcm-cmake/lcm_types_consumer

# Python: byte-compiled by postinst, importable by Debian's python3.
site=/usr/lib/python3/dist-packages
ls "$site"/lidarflow/__pycache__/*.pyc >/dev/null 2>&1 || fail "postinst did not byte-compile lidarflow"
/usr/bin/python3 -c "import lidarflow, lidarflow_lcm; print('import lidarflow:', lidarflow.Estimator.__name__, lidarflow.__version__)"

# The README's drives block as written: lidarflow sequence and lidarflow_dask of the packages.
bash /tmp/consumer/readme_drives.sh --check-installed /tmp/consumer/README.md

# python3-lidarflow with the Python packages that depend on it (python3-lidarflow-*).
py_pkgs="$(dpkg-query -W -f='${Package}\n' 'python3-lidarflow*' | sort -u)"
dpkg --purge $py_pkgs > /tmp/dpkg-purge.log 2>&1 || { cat /tmp/dpkg-purge.log; fail "dpkg --purge $py_pkgs"; }
left="$(find "$site" -path '*lidarflow*')"
[ -z "$left" ] || { echo "$left"; fail "left behind by dpkg --purge $py_pkgs"; }
if out="$(cd / && /usr/bin/python3 -c 'import lidarflow; print(lidarflow.__path__)' 2>&1)"; then
    fail "import lidarflow still works after the purge: $out"
fi
echo "$out" | grep -q "ModuleNotFoundError: No module named 'lidarflow'" || fail "import lidarflow: $out"
echo "after dpkg --purge $(echo $py_pkgs): nothing left in $site; import lidarflow: ModuleNotFoundError"

pkgs="$( (dpkg-query -W -f='${Package}\n' 'liblidarflow*' 'lidarflow*' 2>/dev/null || true) | sort -u)"
dpkg --purge $pkgs > /tmp/dpkg-purge-all.log 2>&1 || { cat /tmp/dpkg-purge-all.log; fail "dpkg --purge $pkgs"; }
find /usr -path '*lidarflow*' | sort > /tmp/after.txt
diff /tmp/before.txt /tmp/after.txt || fail "dpkg --purge of every package left the files above"
echo "after purging $(echo $pkgs): /usr as before"
SCRATCH
echo "deb system check: ok"
