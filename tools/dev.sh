#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Developer entry point: installs what is missing (Debian bookworm, apt-get), builds, and runs.
#   tools/dev.sh demo        build + run the demo on the built-in synthetic scene
#   tools/dev.sh test        build + run every test suite (what CI runs) but the "long" ones
#   tools/dev.sh test-long   build + run the suites labelled "long" (real time: the README's LCM
#                            walkthrough run verbatim, ~2.5 min)
#   tools/dev.sh test-asan   the same under AddressSanitizer + UBSan (build-asan/)
#   tools/dev.sh deps        only install the Debian packages
#   tools/dev.sh build       only configure + build (build/)
#   tools/dev.sh build-clang configure + build everything with Debian's clang 14 (build-clang/)
#   tools/dev.sh test-tsan   build the library with clang 14 + ThreadSanitizer
#                            (build-tsan/), run the C ABI concurrency suites under it (N handles
#                            on N threads; the log callback replaced while frames run; a
#                            handle's own frame workers)
#   tools/dev.sh fuzz [SECONDS] [TARGET...]  build the libFuzzer targets (clang 14, ASan + UBSan,
#                            build-fuzz/) and run each for SECONDS (default 60); fails on a finding
#   tools/dev.sh fuzz-runs [RUNS] [TARGET...]  the same, each for RUNS executions in one process
#                            (default 10^7, the campaign bar)
#   tools/dev.sh fuzz-python [EXECUTIONS]  the mutation fuzzer of the Python LCM decoders and log
#                            reader (bindings/python/tests_lcm/fuzz_lcm.py; default 10^6
#                            executions); fails on a finding, left in build/fuzz-lcm-findings/
#   tools/dev.sh package     build + Debian packages (CPack) in build/packages/, checked by lintian
#   tools/dev.sh pairs-rate [PRESET] [THREADS...]  build, render a 12-frame 1242x375 synthetic
#                            drive, and print `lidarflow sequence`'s pairs/s at each thread count
#                            (default: 1 2 and every power of two up to the CPUs) as one stream
#                            and with frames in flight (2, 4, ... up to the thread count)
#   tools/dev.sh device-bundle  build, then pack the CLI and the shared libraries it loads (but
#                            glibc's) into .device/lidarflow-device.tar.xz, for tools/device_rates.sh
#                            on a machine without the packages (docs/DEVELOPING.md)
#   tools/dev.sh lidar-cost [PRESET] [ROUNDS]  build, then time the KITTI pairs of
#                            $LIDARFLOW_KITTI_DIR with the 88-point and the full-scan LiDAR, the two
#                            bench_pipeline runs alternated ROUNDS times (default 4) at PRESET
#                            (default realtime); prints each round's pair times, their ratio, the
#                            ratio of their means (what the scan costs over 88 points) and of
#                            their medians (less moved by a round another process slowed)
#   tools/dev.sh bridge-rate [PRESET] [HZ] [LOOPS]  build, then play the KITTI frames of
#                            $LIDARFLOW_KITTI_DIR onto LCM (this host only) at HZ frames/s (default
#                            2), LOOPS times (default 10), through the bridge at PRESET (default
#                            default); prints the bridge's final counters (stale drops, results,
#                            latency, the estimator's mean time)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="$(nproc 2>/dev/null || echo 2)"

# Debian bookworm packages the project builds, tests and runs with.
packages=(build-essential cmake pkg-config git
          libopencv-dev libopencv-contrib-dev libeigen3-dev libcmocka-dev nlohmann-json3-dev
          liblcm-dev liblcm-bin libglib2.0-dev libssl-dev iproute2 util-linux
          abigail-tools python3 python3-numpy dpkg-dev file help2man
          python3-pip python3-setuptools python3-wheel python3-venv
          python3-distributed)  # lidarflow_dask and its test (python_dask)

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

run_tests() {  # run_tests DIR [ctest args...]
    kitti_env
    local dir="$1"; shift
    ctest --test-dir "$root/$dir" --output-on-failure -j "$jobs" "$@"
}

# fuzz_one DIR TARGET LIMIT: one libFuzzer run for LIMIT (-max_total_time=S or -runs=N); its exit
# status goes to fuzz-logs/TARGET.rc.
fuzz_one() {
    local dir="$1" t="$2" limit="$3" rc=0
    # -timeout: a C ABI program of 24 calls on images of at most 64x48 px takes well under a
    # second; 60 s means a hang. ASAN_OPTIONS: leaks are findings too (tests/lsan.supp: glibc's).
    ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS="suppressions=$root/tests/lsan.supp" "$dir/tests/fuzz/$t" "$limit" -timeout=60 \
        -rss_limit_mb=4096 -print_final_stats=1 -artifact_prefix="$dir/findings/$t-" \
        "$dir/corpus/$t" "$root/tests/fuzz/corpus/$t" >"$dir/fuzz-logs/$t.log" 2>&1 || rc=$?
    echo "$rc" >"$dir/fuzz-logs/$t.rc"
}

# fuzz LIMIT [TARGET...]: each target (default: all of tests/fuzz) for LIMIT (a libFuzzer flag:
# -max_total_time=S or -runs=N), one per core at a time, from its committed seeds (tests/fuzz/corpus/T) plus what earlier runs found
# (build-fuzz/corpus/T). Findings land in build-fuzz/findings/; logs in build-fuzz/fuzz-logs/.
fuzz() {
    local limit="$1"; shift
    local dir="$root/build-fuzz" targets=("$@") failed=()
    [ ${#targets[@]} -gt 0 ] || targets=(fuzz_targets)
    CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DLIDARFLOW_FUZZ=ON -DLIDARFLOW_BUILD_TESTS=OFF >/dev/null
    cmake --build "$dir" -j "$jobs" --target "${targets[@]}"
    [ "${targets[0]}" != fuzz_targets ] || targets=($(cd "$dir/tests/fuzz" && ls fuzz_* | sort))
    # The committed seeds must still be what they were made as (a message layout change makes
    # them stale: wrong fingerprint): each decodes, or is refused where meant to be.
    if [ -d "$dir/tests/fuzz/CMakeFiles/lidarflow_fuzz_corpus.dir" ]; then  # built with LCM
        cmake --build "$dir" -j "$jobs" --target lidarflow_fuzz_corpus >/dev/null
        "$dir/tests/fuzz/lidarflow_fuzz_corpus" --check "$root/tests/fuzz/corpus" >"$dir/seed-check.log" ||
            { grep -A3 '^BAD' "$dir/seed-check.log"; echo "dev.sh fuzz: stale seeds: rerun" \
              "$dir/tests/fuzz/lidarflow_fuzz_corpus tests/fuzz/corpus"; return 1; }
    fi
    mkdir -p "$dir/findings" "$dir/fuzz-logs"
    # libFuzzer runs one thread per target: the targets run side by side, one per core, each for
    # its own LIMIT (a target's result file says how it ended; its log what it found).
    local running=0
    for t in "${targets[@]}"; do
        mkdir -p "$dir/corpus/$t"
        rm -f "$dir/fuzz-logs/$t.rc"
        while [ "$running" -ge "$jobs" ]; do wait -n || true; running=$((running - 1)); done
        fuzz_one "$dir" "$t" "$limit" &
        running=$((running + 1))
    done
    wait || true
    for t in "${targets[@]}"; do
        local log="$dir/fuzz-logs/$t.log"
        if [ "$(cat "$dir/fuzz-logs/$t.rc" 2>/dev/null)" = 0 ]; then
            printf 'dev.sh fuzz: %-22s %10s runs %7s exec/s  ok\n' "$t" \
                "$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")" \
                "$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")"
        else
            echo "dev.sh fuzz: $t FAILED (log $log):"
            grep -E '^(==[0-9]+==ERROR|SUMMARY|fuzz_capi:|.*runtime error)|Test unit written' "$log" | head -5
            failed+=("$t")
        fi
    done
    [ ${#failed[@]} -eq 0 ] || { echo "dev.sh fuzz: findings in ${failed[*]}"; return 1; }
}

# bridge_rate PRESET HZ LOOPS: whether the bridge keeps up with a KITTI stream of that rate.
bridge_rate() {
    local preset="$1" hz="$2" loops="$3"
    kitti_env
    [ -n "${LIDARFLOW_KITTI_DIR:-}" ] || { echo "dev.sh bridge-rate: needs LIDARFLOW_KITTI_DIR"; return 1; }
    local url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216' log
    log="$(mktemp)"
    "$root/build/bridge/lidarflow-lcm-bridge" --lcm-url "$url" --option "preset=$preset" >"$log" 2>&1 &
    local bridge=$!
    sleep 1  # the bridge subscribes before the first calibration goes out
    "$root/build/tools/lidarflow/lidarflow" publish-kitti --root "$LIDARFLOW_KITTI_DIR" --lidar paper \
        --lcm-url "$url" --rate "$hz" --loop "$loops" >/dev/null
    sleep 4  # the last pair's result
    kill -INT "$bridge"
    wait "$bridge" || true
    grep 'stopped' "$log" || { cat "$log"; rm -f "$log"; return 1; }
    rm -f "$log"
}

# The CLI and every shared library it loads but glibc's, for a machine without Debian's packages
# or a network: tools/device_rates.sh unpacks and runs it there (docs/DEVELOPING.md).
device_bundle() {
    local cli="$root/build/tools/lidarflow/lidarflow" out="$root/.device/lidarflow-device.tar.xz" stage libs n
    libs="$(ldd "$cli")"
    if grep 'not found' <<<"$libs"; then echo "dev.sh device-bundle: libraries missing here" >&2; return 1; fi
    stage="$(mktemp -d)"
    mkdir -p "$stage/bin" "$stage/lib" "$root/.device"
    cp "$cli" "$stage/bin/"
    awk '/=> \// { print $3 }' <<<"$libs" | grep -Ev '/(libc|libm|libpthread|libdl|librt|libresolv)\.so|/ld-linux' |
        xargs -r cp -L -t "$stage/lib"
    n="$(find "$stage/lib" -type f | wc -l)"
    tar -C "$stage" -cf - bin lib | xz -T0 -6 >"$out.tmp"
    mv "$out.tmp" "$out"
    rm -rf "$stage"
    echo "dev.sh device-bundle: $out ($(du -h "$out" | cut -f1), the CLI and $n libraries)"
}

lidar_cost() {
    local preset="$1" rounds="$2" bench="$root/build/bench/bench_pipeline"
    : "${LIDARFLOW_KITTI_DIR:?set LIDARFLOW_KITTI_DIR to the KITTI training folder}"
    # The mean over both frames of bench_pipeline's pair time (median of its 3 runs).
    pair() {
        "$bench" --root "$LIDARFLOW_KITTI_DIR" --runs 3 --no-synth --threads 2 --preset "$preset" --lidar "$1" |
            awk '/^  total/ { s += $2; n++ } END { if (n) printf "%.4f", s / n; else exit 1 }'
    }
    printf '%-6s %-14s %-14s %s\n' round "88 points [s]" "scan [s]" "scan / 88"
    local r sparse dense all=""
    for ((r = 1; r <= rounds; r++)); do
        sparse="$(pair paper)"
        dense="$(pair velodyne)"
        all+="$sparse $dense"$'\n'
        printf '%-6s %-14s %-14s %s\n' "$r" "$sparse" "$dense" "$(awk -v a="$sparse" -v b="$dense" 'BEGIN { printf "%.3f", b / a }')"
    done
    printf '%s' "$all" | awk '{ a += $1; b += $2 } END { printf "means  %-14.4f %-14.4f %.3f\n", a / NR, b / NR, b / a }'
    median() { sort -n | awk '{ v[NR] = $1 } END { printf "%.4f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
    sparse="$(printf '%s' "$all" | awk '{ print $1 }' | median)"
    dense="$(printf '%s' "$all" | awk '{ print $2 }' | median)"
    printf '%-6s %-14s %-14s %s\n' median "$sparse" "$dense" "$(awk -v a="$sparse" -v b="$dense" 'BEGIN { printf "%.3f", b / a }')"
}

case "${1:-}" in
    deps) deps ;;
    build) deps; build build ;;
    demo) deps; build build; shift; "$root/build/tools/lidarflow/lidarflow" demo --out "$root/demo-out" "$@" ;;
    test) deps; build build; run_tests build -LE '^long$' ;;
    test-long) deps; build build; run_tests build -L '^long$' ;;
    test-asan)
        deps
        packages=(clang-14 libclang-rt-14-dev libomp-14-dev); deps  # sanitizer runtimes, OpenMP
        # clang 14, with the benchmarks: CI's release build is gcc's, so both compilers build
        # everything (and with UBSan's checks clang compiles a file in ~2/3 of gcc's time).
        # -g1: line tables only, enough for the sanitizers' file:line stack traces. -O1 (ASan's
        # own advice; -O2 compiled ~10 % longer and ran the suites no faster).
        build build-asan -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DLIDARFLOW_SANITIZE=ON \
            -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLIDARFLOW_BUILD_BENCH=ON \
            "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG"
        # Under the sanitizers, leave out what only repeats covered code at real-time cost: the
        # argument-error script (40 bridge starts), the KITTI-rate and 3-shard udpm runs (the
        # synthetic udpm run stays; memq covers the dead-shard rules), the six KITTI pairs of
        # the raw-Velodyne comparison, the four KITTI-size matcher runs of test_matching_kitti (the
        # golden test runs the same matcher on the same frames), the README LCM walkthrough (real
        # time), and a shorter soak (3,000 messages instead of 10,000).
        # tests/lsan.supp: a glibc buffer that LeakSanitizer may report depending on which
        # thread first starts TBB (the comment there).
        # KMP_HOT_TEAMS_MAX_LEVEL=0: LLVM's OpenMP keeps no idle teams between regions; the
        # descriptors of those it keeps are unreachable at exit and would be reported as leaks.
        KMP_HOT_TEAMS_MAX_LEVEL=0 LF_SOAK_MESSAGES=3000 ASAN_OPTIONS=detect_leaks=1 \
            UBSAN_OPTIONS=print_stacktrace=1 LSAN_OPTIONS="suppressions=$root/tests/lsan.supp" run_tests build-asan \
            -E '^(bridge_args|bridge_udpm_kitti|bridge_udpm_shards|bridge_udpm_shard_dies|bridge_kitti_velodyne|test_matching_kitti|bridge_readme_lcm)$' ;;
    build-clang)
        deps
        packages=(clang-14 libomp-14-dev); deps  # the second compiler and its OpenMP
        CC=clang-14 CXX=clang++-14 build build-clang ;;
    test-tsan)
        deps
        packages=(clang-14 libclang-rt-14-dev libomp-14-dev); deps  # sanitizer runtimes, OpenMP
        CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$root/build-tsan" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
            -DLIDARFLOW_SANITIZE_THREAD=ON -DLIDARFLOW_BUILD_BENCH=OFF >/dev/null
        # The library and the suite only: CI builds the whole tree with clang in test-asan.
        cmake --build "$root/build-tsan" -j "$jobs" --target lidarflow test_capi_concurrent test_capi_log \
            test_capi_frames_in_flight
        # OpenMP stays at one thread per handle in the suite: libgomp is not instrumented, so its
        # barriers would be reported as races. The threads under test are the caller's.
        TSAN_OPTIONS="halt_on_error=1 ${TSAN_OPTIONS:-}" LF_TEST_THREADS=4 LF_TEST_ROUNDS=6 \
            "$root/build-tsan/tests/test_capi_concurrent"
        # The log callback replaced while frames run on three threads.
        TSAN_OPTIONS="halt_on_error=1 ${TSAN_OPTIONS:-}" "$root/build-tsan/tests/test_capi_log"
        # A handle's own frame workers (frames_in_flight), one OpenMP thread per pair.
        TSAN_OPTIONS="halt_on_error=1 ${TSAN_OPTIONS:-}" "$root/build-tsan/tests/test_capi_frames_in_flight" ;;
    fuzz|fuzz-runs)
        deps
        packages=(clang-14 libclang-rt-14-dev libomp-14-dev); deps  # libFuzzer, sanitizer runtimes, OpenMP
        verb="$1"; shift
        if [ "$verb" = fuzz ]; then fuzz "-max_total_time=${1:-60}" "${@:2}"
        else fuzz "-runs=${1:-10000000}" "${@:2}"; fi ;;
    fuzz-python)
        deps
        # Debian's python3 (with python3-numpy from deps), not another one first on PATH.
        py=/usr/bin/python3; [ -x "$py" ] || py=python3
        PYTHONDONTWRITEBYTECODE=1 "$py" "$root/bindings/python/tests_lcm/fuzz_lcm.py" --executions "${2:-1000000}" \
            --findings "$root/build/fuzz-lcm-findings" ;;
    package)
        deps
        packages=(lintian); deps  # only this verb checks the packages
        build build
        rm -rf "$root/build/packages"
        (cd "$root/build" && cpack -G DEB)
        # lintian's errors fail the verb; its warnings are printed (docs/ARCHITECTURE.md lists them).
        lintian --fail-on error "$root"/build/packages/*.deb
        ls -1 "$root"/build/packages/*.deb ;;
    lidar-cost) deps; build build; shift; lidar_cost "${1:-realtime}" "${2:-4}" ;;
    bridge-rate) deps; build build; shift; bridge_rate "${1:-default}" "${2:-2}" "${3:-10}" ;;
    device-bundle) deps; packages=(xz-utils); deps; build build; device_bundle ;;
    pairs-rate)
        deps; build build; shift
        "$root/tools/pairs_rate.sh" "$root/build/tools/lidarflow/lidarflow" "${1:-realtime}" "${@:2}" ;;
    *) awk 'NR > 1 && /^#/ { if (!/SPDX-License-Identifier/) print; next } NR > 1 { exit }' "$0"; exit 2 ;;
esac
