#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, -fsanitize=fuzzer,address,undefined), prepares seed
# corpora and runs every target for SECONDS (default 600), then reports executions and findings.
#
#   bash tests/fuzz/run_fuzzers.sh [SECONDS] [TARGET...]     TARGET: off obj ply stl pipeline
#
# Environment: HOLOFLOW_FUZZ_BUILD (build dir, default <repo>/build-fuzz), FUZZ_PARALLEL (targets
# run at once, default 2), FUZZ_NICE (nice level, default 10), FUZZ_MAX_SEED_BYTES (largest
# libcgal-demo OFF mesh made into seeds, default 16384).
# Dictionaries of each format's keywords: tests/fuzz/dicts/<format>.dict.
# Output under $HOLOFLOW_FUZZ_BUILD/fuzz: corpus/<target> (grows across runs), seeds/<format>,
# artifacts/<target> (crash-*, leak-*, timeout-*, oom-*), logs/<target>.log.
# Exit status: 0 without findings, 1 with findings, 2 on a usage or build problem.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${HOLOFLOW_FUZZ_BUILD:-$here/build-fuzz}"
seconds="${1:-600}"
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(off obj ply stl pipeline)
parallel="${FUZZ_PARALLEL:-2}"
niceness="${FUZZ_NICE:-10}"
max_seed_bytes="${FUZZ_MAX_SEED_BYTES:-16384}"

case "$seconds" in
    '' | *[!0-9]*) echo "run_fuzzers: SECONDS must be a whole number, got '$seconds'" >&2; exit 2 ;;
esac
for t in "${targets[@]}"; do
    case "$t" in
        off | obj | ply | stl | pipeline) ;;
        *) echo "run_fuzzers: unknown target '$t' (off obj ply stl pipeline)" >&2; exit 2 ;;
    esac
done

# --- clang with the libFuzzer runtime ---------------------------------------------------------
if ! command -v clang++ >/dev/null || ! echo 'int main(){}' |
    clang++ -x c++ -fsanitize=fuzzer-no-link -o /dev/null - 2>/dev/null; then
    if [ "$(id -u)" -ne 0 ]; then
        echo "run_fuzzers: clang++ with libFuzzer missing; run as root to install it" >&2
        exit 2
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    apt-get install -y -q --no-install-recommends clang libclang-rt-14-dev
fi

# --- build ------------------------------------------------------------------------------------
cmake -S "$here" -B "$build" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DHOLOFLOW_FUZZ=ON -DHOLOFLOW_BUILD_TESTS=OFF -DHOLOFLOW_BUILD_BENCH=OFF >/dev/null ||
    { echo "run_fuzzers: configure failed" >&2; exit 2; }
nice -n "$niceness" cmake --build "$build" --target holoflow_fuzz -j 2 ||
    { echo "run_fuzzers: build failed" >&2; exit 2; }

# --- seed corpora -----------------------------------------------------------------------------
out="$build/fuzz"
mkdir -p "$out/seeds" "$out/corpus" "$out/artifacts" "$out/logs"
meshes=()
if [ -d "$build/data/meshes" ]; then
    while IFS= read -r m; do meshes+=("$m"); done < <(
        find "$build/data/meshes" -maxdepth 1 -name '*.off' -size -"$((max_seed_bytes + 1))"c | sort)
fi
rm -rf "$out/seeds"
mkdir -p "$out/seeds"
if [ ${#meshes[@]} -gt 0 ]; then
    ASAN_OPTIONS=detect_leaks=0 "$build/tests/fuzz/holoflow_fuzz_seeds" "$out/seeds" "${meshes[@]}" \
        2>/dev/null
else
    echo "run_fuzzers: no libcgal-demo meshes in $build/data/meshes; handmade seeds only" >&2
fi
for format in off obj ply stl; do
    mkdir -p "$out/seeds/$format"
    if [ -d "$here/tests/fuzz/seeds/$format" ]; then
        cp "$here/tests/fuzz/seeds/$format"/* "$out/seeds/$format"/ 2>/dev/null || true
    fi
done

# --- run --------------------------------------------------------------------------------------
# Leak checks on, UB fatal; one BLAS thread (CHOLMOD) so that runs are reproducible and cheap.
export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

run_one() {
    local t="$1" format="$1"
    [ "$t" = pipeline ] && format=off
    mkdir -p "$out/corpus/$t" "$out/artifacts/$t"
    # -timeout: one input over 10 s is a hang; -rss_limit_mb: 2 GB is an OOM on small inputs.
    nice -n "$niceness" "$build/tests/fuzz/holoflow_fuzz_$t" -dict="$here/tests/fuzz/dicts/$format.dict" \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$out/artifacts/$t/" "$out/corpus/$t" "$out/seeds/$format" \
        >"$out/logs/$t.log" 2>&1 || true
}

echo "run_fuzzers: ${targets[*]} for ${seconds} s each, $parallel at a time (logs in $out/logs)"
running=0
for t in "${targets[@]}"; do
    run_one "$t" &
    running=$((running + 1))
    if [ "$running" -ge "$parallel" ]; then
        wait -n || true
        running=$((running - 1))
    fi
done
wait

# --- report -----------------------------------------------------------------------------------
findings=0
printf '%-9s %14s %10s %8s %9s  %s\n' target executions corpus rss_mb findings artifacts
for t in "${targets[@]}"; do
    log="$out/logs/$t.log"
    execs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)"
    rss="$(grep -o 'stat::peak_rss_mb: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)"
    corpus="$(find "$out/corpus/$t" -type f | wc -l)"
    kinds="$(grep -o 'ERROR: libFuzzer: [a-z-]*\|ERROR: AddressSanitizer: [a-z-]*\|ERROR: LeakSanitizer: [a-z-]*\|runtime error:.*\|fuzz invariant failed.*\|uncaught exception\|deadly signal' "$log" | sort -u | tr '\n' ';' || true)"
    artifacts="$(find "$out/artifacts/$t" -type f -newer "$out/seeds" 2>/dev/null | wc -l)"
    n=0
    if [ -n "$kinds" ] || [ "$artifacts" -gt 0 ]; then n=1; findings=$((findings + 1)); fi
    printf '%-9s %14s %10s %8s %9s  %s\n' "$t" "${execs:-?}" "$corpus" "${rss:-?}" "$n" \
        "$(find "$out/artifacts/$t" -type f -newer "$out/seeds" 2>/dev/null | tr '\n' ' ')"
    [ -n "$kinds" ] && echo "          $kinds"
done
if [ "$findings" -gt 0 ]; then
    echo "run_fuzzers: $findings target(s) with findings; reproduce with" \
        "$build/tests/fuzz/holoflow_fuzz_<target> <artifact>"
    exit 1
fi
echo "run_fuzzers: no findings"
