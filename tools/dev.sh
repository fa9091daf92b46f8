#!/usr/bin/env bash
# Developer entry point: installs what is missing (Debian bookworm, apt-get), builds, and runs.
#   tools/dev.sh demo        build + run the demo on the built-in synthetic scene
#   tools/dev.sh test        build + run every test suite (what CI runs)
#   tools/dev.sh test-asan   the same under AddressSanitizer + UBSan (build-asan/)
#   tools/dev.sh deps        only install the Debian packages
#   tools/dev.sh build       only configure + build (build/)
#   tools/dev.sh build-clang configure + build everything with Debian's clang 14 (build-clang/)
#   tools/dev.sh package     build + Debian packages (CPack) in build/packages/, checked by lintian
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="$(nproc 2>/dev/null || echo 2)"

# Debian bookworm packages the project builds, tests and runs with.
packages=(build-essential cmake pkg-config git
          libopencv-dev libopencv-contrib-dev libeigen3-dev libcmocka-dev
          liblcm-dev liblcm-bin libglib2.0-dev iproute2 util-linux
          abigail-tools python3 python3-numpy dpkg-dev file)

deps() {
    local missing=()
    for p in "${packages[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    echo "dev.sh: installing ${missing[*]}"
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# The shared KITTI frames, when this checkout sits beside shared/ (as in CI).
kitti_env() {
    if [ -z "${LIDARFLOW_KITTI_DIR:-}" ] && [ -d "$root/../shared/data/kitti2015/training" ]; then
        export LIDARFLOW_KITTI_DIR="$root/../shared/data/kitti2015/training"
    fi
    if [ -n "${LIDARFLOW_KITTI_DIR:-}" ]; then
        echo "dev.sh: KITTI frames from $LIDARFLOW_KITTI_DIR"
    else
        echo "dev.sh: LIDARFLOW_KITTI_DIR not set: KITTI suites will be skipped"
    fi
}

build() {  # build DIR [cmake args...]
    local dir="$1"; shift
    cmake -S "$root" -B "$root/$dir" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
    cmake --build "$root/$dir" -j "$jobs"
}

run_tests() {  # run_tests DIR
    kitti_env
    ctest --test-dir "$root/$1" --output-on-failure -j "$jobs"
}

case "${1:-}" in
    deps) deps ;;
    build) deps; build build ;;
    demo) deps; build build; shift; "$root/build/tools/lidarflow/lidarflow" demo --out "$root/demo-out" "$@" ;;
    test) deps; build build; run_tests build ;;
    test-asan)
        deps
        build build-asan -DLIDARFLOW_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo
        ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 run_tests build-asan ;;
    build-clang)
        deps
        packages=(clang-14); deps  # only this verb needs the second compiler
        CC=clang-14 CXX=clang++-14 build build-clang ;;
    package)
        deps
        packages=(lintian); deps  # only this verb checks the packages
        build build
        rm -rf "$root/build/packages"
        (cd "$root/build" && cpack -G DEB)
        # lintian's errors fail the verb; its warnings are printed (docs/ARCHITECTURE.md lists them).
        lintian --fail-on error "$root"/build/packages/*.deb
        ls -1 "$root"/build/packages/*.deb ;;
    *) sed -n '2,10p' "$0"; exit 2 ;;
esac
