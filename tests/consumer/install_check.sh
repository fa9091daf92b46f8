#!/usr/bin/env bash
# Installs the build tree into a scratch prefix, then builds consumer.c twice from the
# installed tree only: once with pkg-config, once with CMake find_package(lidarflow).
set -euo pipefail
build="$1"; src="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"
prefix="$work/prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
libdir="$(dirname "$(find "$prefix" -name lidarflow.pc | head -1)")/.."
export PKG_CONFIG_PATH="$libdir/pkgconfig"
# The .pc file bakes in the configure-time prefix; point it at the scratch prefix.
sed -i "s|^prefix=.*|prefix=$prefix|" "$libdir/pkgconfig/lidarflow.pc"
cc -std=c99 -Wall -Wextra -Werror -pedantic "$src/consumer.c" -o "$work/consumer_pc" \
   $(pkg-config --cflags --libs lidarflow)
LD_LIBRARY_PATH="$libdir" "$work/consumer_pc"
cmake -S "$src" -B "$work/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/cmake-build" >/dev/null
LD_LIBRARY_PATH="$libdir" "$work/cmake-build/consumer"
# Only the C ABI is exported.
so="$(find "$prefix" -name 'liblidarflow.so.*' -type f | head -1)"
bad="$(nm -D --defined-only "$so" | awk '$2 ~ /[TDBRW]/ {print $3}' | grep -v '^lf_' | grep -v '^LIDARFLOW_' || true)"
if [ -n "$bad" ]; then echo "unexpected exported symbols:"; echo "$bad"; exit 1; fi
readelf -d "$so" | grep -q "SONAME.*liblidarflow.so.0" || { echo "SONAME is not liblidarflow.so.0"; exit 1; }
echo "install check: ok"
