#!/usr/bin/env bash
# Installs the build tree into a scratch prefix, then builds consumer.c twice from the
# installed tree only: once with pkg-config, once with CMake find_package(lidarflow). Both
# consumers run the full pipeline on a synthetic scene and must write exactly the result
# `lidarflow run` writes for the same input and settings (same KITTI PNG bytes).
#   install_check.sh BUILD SRC WORK CLI HARNESS
set -euo pipefail
build="$1"; src="$2"; work="$3"; cli="$4"; harness="$5"
rm -rf "$work"; mkdir -p "$work"
prefix="$work/prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
libdir="$(dirname "$(find "$prefix" -name lidarflow.pc | head -1)")/.."
export PKG_CONFIG_PATH="$libdir/pkgconfig"
# The .pc file bakes in the configure-time prefix; point it at the scratch prefix.
sed -i "s|^prefix=.*|prefix=$prefix|" "$libdir/pkgconfig/lidarflow.pc"
cc -std=c99 -Wall -Wextra -Werror -pedantic "$src/consumer.c" -o "$work/consumer_pc" \
   $(pkg-config --cflags --libs lidarflow)
cmake -S "$src" -B "$work/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/cmake-build" >/dev/null

# Only the C ABI is exported.
so="$(find "$prefix" -name 'liblidarflow.so.*' -type f | head -1)"
bad="$(nm -D --defined-only "$so" | awk '$2 ~ /[TDBRW]/ {print $3}' | grep -v '^lf_' | grep -v '^LIDARFLOW_' || true)"
if [ -n "$bad" ]; then echo "unexpected exported symbols:"; echo "$bad"; exit 1; fi
readelf -d "$so" | grep -q "SONAME.*liblidarflow.so.0" || { echo "SONAME is not liblidarflow.so.0"; exit 1; }

# The reference: `lidarflow run` on a rendered scene (defaults: LiDAR on, dense result).
scene="$work/scene"; id=000000
"$cli" synth --out "$scene" --width 320 --height 96 --seed 3 >/dev/null
"$cli" run --left0 "$scene/image_2/${id}_10.png" --right0 "$scene/image_3/${id}_10.png" \
           --left1 "$scene/image_2/${id}_11.png" --right1 "$scene/image_3/${id}_11.png" \
           --lidar0 "$scene/lidar_0/${id}_10.png" --lidar1 "$scene/lidar_1/${id}_10.png" \
           --calib "$scene/calib_cam_to_cam/${id}.txt" --threads 2 --out "$work/run" >/dev/null
# The consumers read plain files (PNM images, text LiDAR lists, text calibration).
mkdir -p "$work/raw"
"$harness" to-raw "$scene" "$id" "$work/raw"
for consumer in "$work/consumer_pc" "$work/cmake-build/consumer"; do
    name="$(basename "$(dirname "$consumer")")-$(basename "$consumer")"
    mkdir -p "$work/$name"
    LD_LIBRARY_PATH="$libdir" "$consumer" "$work/raw" "$work/$name"
    "$harness" to-kitti "$work/$name" "$work/$name-kitti" "$id"
    for map in disp_0 disp_1 flow; do
        cmp "$work/run/$map/${id}_10.png" "$work/$name-kitti/$map/${id}_10.png" ||
            { echo "$consumer: $map differs from lidarflow run"; exit 1; }
    done
    echo "$consumer: same disp_0, disp_1 and flow as lidarflow run"
done
echo "install check: ok"
