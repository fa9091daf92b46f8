#!/usr/bin/env bash
# Developer entry point: installs what is missing (Debian bookworm, apt-get), builds, and runs.
#   tools/dev.sh demo        build + run the demo on the built-in synthetic scene
#   tools/dev.sh test        build + run every test suite (what CI runs)
#   tools/dev.sh test-asan   the same under AddressSanitizer + UBSan (build-asan/)
#   tools/dev.sh deps        only install the Debian packages
#   tools/dev.sh build       only configure + build (build/)
#   tools/dev.sh build-clang configure + build everything with Debian's clang 14 (build-clang/)
#   tools/dev.sh test-tsan   build everything with clang 14 + ThreadSanitizer (build-tsan/), run the
#                            C ABI concurrency suite under it (N handles on N threads)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="$(nproc 2>/dev/null || echo 2)"

# Debian bookworm packages the project builds, tests and runs with.
packages=(build-essential cmake pkg-config git
          libopencv-dev libopencv-contrib-dev libeigen3-dev libcmocka-dev
          liblcm-dev liblcm-bin libglib2.0-dev iproute2 util-linux
          abigail-tools python3 python3-numpy
          python3-pip python3-setuptools python3-wheel python3-venv)

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
    test-tsan)
        deps
        packages=(clang-14); deps
        CC=clang-14 CXX=clang++-14 build build-tsan -DLIDARFLOW_SANITIZE_THREAD=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo
        # OpenMP stays at one thread per handle in the suite: libgomp is not instrumented, so its
        # barriers would be reported as races. The threads under test are the caller's.
        TSAN_OPTIONS="halt_on_error=1 ${TSAN_OPTIONS:-}" LF_TEST_THREADS=4 LF_TEST_ROUNDS=6 \
            "$root/build-tsan/tests/test_capi_concurrent" ;;
    *) sed -n '2,11p' "$0"; exit 2 ;;
esac
