#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds and runs programs against an installed lidarflow tree only, never the build tree:
#   prefix  `cmake --install BUILD --prefix WORK/prefix`, then the README's "Install" commands
#           verbatim from a scratch folder (HOME points into WORK)
#   deb     the Debian packages (cpack -G DEB) unpacked with dpkg-deb -x into WORK/root;
#           exits 77 (skipped) when dpkg-deb, dpkg-shlibdeps or cpack are missing
# In both: consumer.c is built with pkg-config and with CMake find_package(lidarflow); both
# run the full pipeline on a synthetic scene and must write exactly the result `lidarflow run`
# writes for the same input and settings (same KITTI PNG bytes). The C++ header lidarflow.hpp
# compiles alone and with OpenCV, and the C++ example (examples/cpp) is built with pkg-config and
# with CMake and writes its .flo (also for KITTI 000002/000003 when LIDARFLOW_KITTI_DIR names
# them). The installed tools must start without LD_LIBRARY_PATH (and `synth --drive` + `sequence`
# run from the installed tree), and the installed LCM types
# must compile.
#   install_check.sh prefix|deb BUILD SRC WORK CLI HARNESS
set -euo pipefail
mode="$1"; build="$2"; src="$3"; work="$4"; cli="$5"; harness="$6"
root="$(cd "$src/../.." && pwd)"
rm -rf "$work"; mkdir -p "$work"
unset LD_LIBRARY_PATH PKG_CONFIG_PATH CMAKE_PREFIX_PATH

case "$mode" in
    prefix)
        prefix="$work/prefix"
        cmake --install "$build" --prefix "$prefix" >/dev/null ;;
    deb)
        for tool in dpkg-deb dpkg-shlibdeps cpack; do
            command -v "$tool" >/dev/null || { echo "deb check skipped: no $tool"; exit 77; }
        done
        cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/packages" >"$work/cpack.log" 2>&1 ||
            { cat "$work/cpack.log"; exit 1; }
        debs=("$work"/packages/*.deb)
        [ ${#debs[@]} -ge 5 ] || { echo "expected 5 packages, got: ${debs[*]}"; exit 1; }
        for deb in "${debs[@]}"; do dpkg-deb -x "$deb" "$work/root"; done
        prefix="$work/root/usr" ;;
    *) echo "usage: install_check.sh prefix|deb BUILD SRC WORK CLI HARNESS"; exit 2 ;;
esac

pc="$(find "$prefix" -name lidarflow.pc | head -1)"
[ -n "$pc" ] || { echo "no lidarflow.pc under $prefix"; exit 1; }
libdir="$(cd "$(dirname "$pc")/.." && pwd)"
lcm_pc="$(find "$prefix" -name lidarflow-lcm-types.pc | head -1)"
if grep -rqs -- "$build" "$libdir/cmake" "$pc" ${lcm_pc:+"$lcm_pc"}; then
    echo "installed CMake/pkg-config files name the build tree"; exit 1
fi
if [ "$mode" = prefix ]; then
    # Relocatable: the .pc files find the prefix from their own place.
    for f in "$pc" ${lcm_pc:+"$lcm_pc"}; do
        grep -q '^prefix=${pcfiledir}/' "$f" || { echo "$f is not relative to itself:"; cat "$f"; exit 1; }
    done
    export PKG_CONFIG_PATH="$libdir/pkgconfig"
else
    # The packages' layout: the library in the multiarch libdir, .pc files with plain /usr paths
    # (no "..", nothing relative), what pkg-config prints on the installed system.
    multiarch="$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || gcc -print-multiarch)"
    [ "$libdir" = "$prefix/lib/$multiarch" ] || { echo "lidarflow.pc in $libdir, not in lib/$multiarch"; exit 1; }
    [ -f "$libdir/liblidarflow.so.0" ] && [ -z "$(find "$prefix/lib" -maxdepth 1 -name 'liblidarflow*')" ] ||
        { echo "liblidarflow not (only) in lib/$multiarch:"; find "$prefix" -name 'liblidarflow*'; exit 1; }
    [ -z "$lcm_pc" ] || [ "$lcm_pc" = "$prefix/share/pkgconfig/lidarflow-lcm-types.pc" ] ||
        { echo "lidarflow-lcm-types.pc (Architecture: all) not in share/pkgconfig: $lcm_pc"; exit 1; }
    for f in "$pc" ${lcm_pc:+"$lcm_pc"}; do
        grep -q '^prefix=/usr$' "$f" && ! grep -q '\.\.\|pcfiledir' "$f" || { echo "$f is not plain /usr:"; cat "$f"; exit 1; }
    done
    # (echo: pkgconf ends its output with a space)
    flags="$(echo $(PKG_CONFIG_PATH="$libdir/pkgconfig" PKG_CONFIG_ALLOW_SYSTEM_CFLAGS=1 PKG_CONFIG_ALLOW_SYSTEM_LIBS=1 \
             pkg-config --cflags --libs lidarflow))"
    echo "pkg-config --cflags --libs lidarflow (system paths kept): $flags"
    [ "$flags" = "-I/usr/include -L/usr/lib/$multiarch -llidarflow" ] || { echo "not normalised: $flags"; exit 1; }
    # The unpacked tree stands in for /usr: copies of the .pc files with its path as prefix (a
    # sysroot would move the system's opencv4 and lcm paths too).
    mkdir -p "$work/pkgconfig"
    for f in "$pc" ${lcm_pc:+"$lcm_pc"}; do
        sed "s|^prefix=/usr\$|prefix=$prefix|" "$f" > "$work/pkgconfig/$(basename "$f")"
    done
    export PKG_CONFIG_PATH="$work/pkgconfig"
fi

# The tools start from the installed tree alone (RUNPATH relative to themselves).
for tool in lidarflow lidarflow-lcm-bridge; do
    exe="$prefix/bin/$tool"
    [ -x "$exe" ] || { [ "$tool" = lidarflow-lcm-bridge ] && [ ! -e "$build/bridge" ] && continue
                       echo "$exe missing"; exit 1; }
    readelf -d "$exe" | grep -q 'RUNPATH.*\$ORIGIN/\.\./lib' || { echo "$exe: no RUNPATH \$ORIGIN/../lib"; exit 1; }
    "$exe" --help >/dev/null || { echo "$exe does not start"; exit 1; }
done

cc -std=c99 -Wall -Wextra -Werror -pedantic "$src/consumer.c" -o "$work/consumer_pc" \
   $(pkg-config --cflags --libs lidarflow)
cmake -S "$src" -B "$work/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/cmake-build" >/dev/null

# The C++ API (lidarflow.hpp, header-only): the installed header compiles with strict warnings
# on its own (pkg-config's flags only) and with OpenCV (its headers as system headers, so that
# only lidarflow.hpp's warnings count).
cat > "$work/hpp_only.cpp" <<'CPP'
#include <lidarflow/lidarflow.hpp>
int main() { return lidarflow::abi_major() == LF_ABI_MAJOR && !LIDARFLOW_USE_OPENCV ? 0 : 1; }
CPP
strict=(-std=c++17 -Wall -Wextra -Wshadow -Wconversion -Wsign-conversion -Wold-style-cast -pedantic -Werror)
c++ "${strict[@]}" "$work/hpp_only.cpp" -o "$work/hpp_only" $(pkg-config --cflags --libs lidarflow)
LD_LIBRARY_PATH="$libdir" "$work/hpp_only" || { echo "lidarflow.hpp alone: wrong ABI or OpenCV detected"; exit 1; }
cat > "$work/hpp_opencv.cpp" <<'CPP'
#include <lidarflow/lidarflow.hpp>
int main() { return lidarflow::ImageView::from_mat(cv::Mat(2, 3, CV_8UC3)).width == 3 ? 0 : 1; }
CPP
c++ "${strict[@]}" "$work/hpp_opencv.cpp" -o "$work/hpp_opencv" \
    $(pkg-config --cflags-only-I opencv4 | sed 's/-I/-isystem /g') $(pkg-config --cflags --libs lidarflow) \
    $(pkg-config --libs opencv4)
LD_LIBRARY_PATH="$libdir" "$work/hpp_opencv" || { echo "lidarflow.hpp with OpenCV failed"; exit 1; }
# The C++ example (examples/cpp: lidarflow.hpp and OpenCV) built with pkg-config and with CMake
# find_package(lidarflow); both write the synthetic scene's flow with cv::writeOpticalFlow, read
# it back, and find the true motion (the example's exit status: within 0.5 px of it).
c++ -std=c++17 -Wall -Wextra "$root/examples/cpp/lidarflow_flow.cpp" -o "$work/cpp_example_pc" \
    $(pkg-config --cflags --libs lidarflow opencv4)
cmake -S "$root/examples/cpp" -B "$work/cpp-cmake-build" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/cpp-cmake-build" >/dev/null
for exe in "$work/cpp_example_pc" "$work/cpp-cmake-build/lidarflow_flow"; do
    out="$work/$(basename "$exe")-out"
    LD_LIBRARY_PATH="$libdir" "$exe" --out "$out" > "$work/cpp_example.log" ||
        { cat "$work/cpp_example.log"; echo "$exe failed"; exit 1; }
    grep -q "mean flow u [0-9.]* px (truth 4)" "$work/cpp_example.log" && [ -s "$out/synthetic.flo" ] ||
        { cat "$work/cpp_example.log"; echo "$exe: no true motion or no synthetic.flo"; exit 1; }
    echo "$exe: wrote $out/synthetic.flo with the true motion"
done
# With the shared KITTI frames (LIDARFLOW_KITTI_DIR), the installed-tree example runs them too.
if [ -d "${LIDARFLOW_KITTI_DIR:-}" ]; then
    out="$work/cpp-kitti-out"
    LD_LIBRARY_PATH="$libdir" "$work/cpp-cmake-build/lidarflow_flow" --root "$LIDARFLOW_KITTI_DIR" --threads 2 \
        --out "$out" || { echo "C++ example on $LIDARFLOW_KITTI_DIR failed"; exit 1; }
    [ -s "$out/000002_10.flo" ] && [ -s "$out/000003_10.flo" ] || { echo "C++ example wrote no KITTI .flo"; exit 1; }
fi

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

# A recorded drive with the installed tool: `synth --drive` writes one, `sequence` computes it.
"$prefix/bin/lidarflow" synth --drive "$work/drive" --frames 3 --width 320 --height 96 >/dev/null
"$prefix/bin/lidarflow" sequence --drive "$work/drive" --out "$work/drive_flow" --preset realtime --quiet
for pair in 0000000000 0000000001; do
    [ -s "$work/drive_flow/flow/$pair.png" ] || { echo "installed sequence wrote no flow/$pair.png"; exit 1; }
done

# LCM types: definitions, generated C (header + source) and C++ headers, used together, through
# lidarflow-lcm-types.pc and through find_package(lidarflow COMPONENTS lcm_types).
if [ -d "$prefix/share/lidarflow/lcm" ]; then
    [ "$(ls "$prefix"/share/lidarflow/lcm/*.lcm | wc -l)" -eq 7 ] || { echo "missing .lcm files"; exit 1; }
    [ -n "$lcm_pc" ] || { echo "no lidarflow-lcm-types.pc"; exit 1; }
    csources="$(pkg-config --variable=csourcedir lidarflow-lcm-types)"
    [ -f "$csources/lidarflow_status_t.c" ] || { echo "no C sources in $csources"; exit 1; }
    cc -std=c99 -c "$csources/lidarflow_status_t.c" $(pkg-config --cflags lidarflow-lcm-types) \
       -o "$work/lidarflow_status_t.o"
    c++ -std=c++17 -Wall -Wextra -Werror "$src/lcm_types_consumer.cpp" "$work/lidarflow_status_t.o" \
        $(pkg-config --cflags --libs lidarflow-lcm-types) -o "$work/lcm_types_consumer"
    "$work/lcm_types_consumer"
    cmake -S "$src/lcm_types" -B "$work/lcm-cmake-build" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
    cmake --build "$work/lcm-cmake-build" >/dev/null
    "$work/lcm-cmake-build/lcm_types_consumer"
elif [ -e "$build/lcm_types" ]; then
    echo "LCM build has no installed LCM types"; exit 1
fi

# lidarflow_lcm, imported from the installed tree (never the checkout), decodes the log the
# installed `lidarflow publish-kitti` writes (liblcm's writer, lcm-gen's C encoders).
pydir="$prefix/lib/python3/dist-packages"
[ -f "$pydir/lidarflow_lcm/__init__.py" ] || { echo "lidarflow_lcm not installed in $pydir"; exit 1; }
if [ -d "$prefix/share/lidarflow/lcm" ]; then
    "$prefix/bin/lidarflow" publish-kitti --root "$scene" --lidar paper --rate 0 \
        --lcm-url "file://$work/scene.log?mode=w" >/dev/null
    (cd "$work" && PYTHONPATH="$pydir" PYTHONDONTWRITEBYTECODE=1 /usr/bin/python3 - "$pydir" "$work/scene.log" <<'PY'
import os, sys
import lidarflow_lcm as ll
assert os.path.dirname(os.path.dirname(os.path.abspath(ll.__file__))) == os.path.abspath(sys.argv[1]), ll.__file__
kinds = [type(m).__name__ for _, m in ll.read_messages(sys.argv[2], strict=True)]
assert sorted(set(kinds)) == ["calibration_t", "lidar_t", "stereo_t"] and kinds.count("stereo_t") == 2, kinds
print("installed lidarflow_lcm decodes the installed publisher's log:", len(kinds), "messages")
PY
    ) || { echo "installed lidarflow_lcm failed"; exit 1; }
fi

# lidarflow_dask, installed, finds the tools of its own prefix with no variable and no PATH.
[ -f "$pydir/lidarflow_dask/__main__.py" ] || { echo "lidarflow_dask not installed in $pydir"; exit 1; }
found="$(cd "$work" && env -u LIDARFLOW_BIN_DIR PATH=/usr/bin:/bin PYTHONPATH="$pydir" PYTHONDONTWRITEBYTECODE=1 \
         /usr/bin/python3 -c 'import lidarflow_dask as d; print(d.find_tool("lidarflow"))')" ||
    { echo "installed lidarflow_dask failed"; exit 1; }
[ "$found" = "$prefix/bin/lidarflow" ] || { echo "installed lidarflow_dask found '$found', not $prefix/bin/lidarflow"; exit 1; }

# Licence and notices are installed.
if [ "$mode" = prefix ]; then
    for f in LICENSE THIRD_PARTY_NOTICES.md; do
        [ -s "$prefix/share/doc/lidarflow/$f" ] || { echo "share/doc/lidarflow/$f missing"; exit 1; }
    done
else
    for deb in "${debs[@]}"; do
        pkg="$(dpkg-deb -f "$deb" Package)"
        grep -q "^License: Expat" "$prefix/share/doc/$pkg/copyright" || { echo "$pkg: no copyright"; exit 1; }
    done
fi

# The README's install commands, verbatim, typed by a user in a checkout (scratch folder with
# the checkout's examples/ and the build tree as build/) whose HOME is in WORK.
if [ "$mode" = prefix ]; then
    user="$work/user"; mkdir -p "$user/home"
    ln -s "$build" "$user/build"; ln -s "$root/examples" "$user/examples"
    awk '/<!-- install-check: begin -->/ {on=1; next} /<!-- install-check: end -->/ {on=0}
         on && !/^```/' "$root/README.md" > "$work/readme_install.sh"
    [ -s "$work/readme_install.sh" ] || { echo "README has no install-check block"; exit 1; }
    # A python3 without numpy first on PATH, as pyenv's is on many machines: the README's commands
    # must name Debian's /usr/bin/python3 where they need numpy.
    mkdir -p "$work/other-python"
    printf '#!/bin/sh\necho "python3 without numpy: ModuleNotFoundError: No module named numpy" >&2\nexit 1\n' \
        > "$work/other-python/python3"
    chmod +x "$work/other-python/python3"
    (cd "$user" && HOME="$user/home" PATH="$work/other-python:$PATH" bash -euo pipefail -x "$work/readme_install.sh") \
        > "$work/readme_install.log" 2>&1 || { cat "$work/readme_install.log"; echo "README install commands failed"; exit 1; }
    # capi_example twice (pkg-config, CMake), python_example once: each with the true motion
    # (the C++ example's line, should the README run it too, says "(C++)" and is not counted).
    # "true": within 0.5 px of the 4 px motion.
    near_truth() { grep -v "(C++)" "$work/readme_install.log" | grep -oE "$1 [0-9.-]+ px \(truth 4\)" |
        awk '{ v = $(NF - 3); if (v > 3.5 && v < 4.5) n++ } END { print n + 0 }'; }
    [ "$(near_truth "mean flow u")" -eq 2 ] && [ "$(near_truth "mean u")" -eq 1 ] ||
        { cat "$work/readme_install.log"; echo "README examples did not print the true motion"; exit 1; }
    echo "README install commands: ok"
fi
echo "install check ($mode): ok"
