#!/usr/bin/env bash
# One-step set-up on Debian 12 (as root): install the packages, configure, build, then
#   bootstrap.sh demo [MESH]   run the main job on a default model (or MESH)
#   bootstrap.sh test          run the whole test suite (what CI runs)
#   bootstrap.sh tsan          only the ThreadSanitizer stage of `test`
# Both README commands and .ci/run go through here so that they cannot drift apart.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HOLOFLOW_BUILD_DIR:-$here/build}"
jobs="$(nproc)"
# The sanitizer builds compile at -O1 with line tables only (-g1): reports still name file:line and
# ASan/TSan stay fast enough at -O1, while the build of the heavy dense-Eigen kernels takes half as
# long as at -O2 -g (kernels/src/holomorphic.cpp under ASan: 105 s -> 50 s on one core).
sanitizer_build_flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG")

# Ninja keeps both cores busy across target boundaries (the Makefile generator waits for each
# library before compiling what links it: 5m05s -> 4m17s for the Release build).
# configure DIR ARGS...: cmake -G Ninja, starting DIR afresh if another generator made it.
configure() {
  local dir="$1"
  shift
  if [ -f "$dir/CMakeCache.txt" ] && ! grep -qx 'CMAKE_GENERATOR:INTERNAL=Ninja' "$dir/CMakeCache.txt"; then
    rm -rf "$dir/CMakeCache.txt" "$dir/CMakeFiles"
  fi
  cmake -G Ninja -S "$here" -B "$dir" "$@"
}

# Prints how long the named stage took since the previous call, for the CI log.
stage_clock=$SECONDS
stage_done() {
  echo "bootstrap: $1 took $((SECONDS - stage_clock)) s"
  stage_clock=$SECONDS
}

packages=(
  cmake g++ make ninja-build pkg-config
  libtbb-dev libeigen3-dev libopenmesh-dev
  libsuitesparse-dev libopenblas0-pthread libopenblas-pthread-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev
  libcgal-demo  # real test meshes: /usr/share/doc/libcgal-dev/data.tar.gz
  assimp-testmodels  # other tools' test files (STL, PLY, OBJ exports): /usr/share/assimp/models
)

install_packages() {
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "bootstrap: missing packages (${missing[*]}); run as root to install them" >&2
    exit 1
  fi
  echo "bootstrap: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# ThreadSanitizer on the flow-graph tests (the graphs/ tests and engine_batch_test, whose
# `holoflow batch` runs drive the collection graph). Debian's libtbb is not instrumented: TSan would
# miss every happens-before edge of the scheduler and report each hand-over between tasks. So the
# stage builds Debian's own oneTBB source (deb-src, same compiler) with -fsanitize=thread once into
# "$build-tsan/onetbb" (libtbb only; later runs reuse it) and links the tests against that.
tsan_stage() {
  local tsan="$build-tsan"
  local tbb="$tsan/onetbb"
  if [ ! -f "$tbb/built" ]; then
    fetch_tbb_source "$tbb/src"
    local src=("$tbb"/src/onetbb-*/)
    # -Wno-tsan: GCC 12 warns (an error under oneTBB's -Werror) that TSan does not model
    # atomic_thread_fence, which oneTBB uses only in its sleep/wake-up handshakes; tasks and their
    # data are handed over through atomics and locks, which TSan does see.
    rm -rf "$tbb/build" "$tbb/prefix"
    if ! { cmake -S "${src[0]}" -B "$tbb/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS=-Wno-tsan \
             -DTBB_SANITIZE=thread -DTBB_TEST=OFF -DTBB_EXAMPLES=OFF -DTBBMALLOC_BUILD=OFF -DTBB4PY_BUILD=OFF \
             -DTBB_DISABLE_HWLOC_AUTOMATIC_SEARCH=ON -DCMAKE_INSTALL_PREFIX="$tbb/prefix" &&
           cmake --build "$tbb/build" -j "$jobs" && cmake --install "$tbb/build"; } >"$tbb/build.log" 2>&1; then
      tail -n 40 "$tbb/build.log" >&2
      echo "bootstrap: building the TSan libtbb failed (log: $tbb/build.log)" >&2
      exit 1
    fi
    local dsc=("$tbb"/src/onetbb_*.dsc)
    basename "${dsc[0]}" .dsc >"$tbb/built"
    stage_done "building the TSan libtbb"
  fi
  echo "bootstrap: TSan libtbb from $(cat "$tbb/built") in $tbb/prefix"

  # One executable per test file here (HOLOFLOW_TEST_UNITY=OFF): only these files are built.
  local targets=(engine_batch_test) t
  for t in "$here"/tests/graphs/*_test.cpp; do targets+=("graphs_$(basename "$t" .cpp)"); done
  configure "$tsan" "${sanitizer_build_flags[@]}" -DHOLOFLOW_BUILD_TESTS=ON -DHOLOFLOW_TEST_UNITY=OFF \
    -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" -DHOLOFLOW_BUILD_BENCH=OFF \
    -DTBB_DIR="$tbb/prefix/lib/cmake/TBB"
  cmake --build "$tsan" -j "$jobs" --target "${targets[@]}"
  stage_done "the TSan build"
  # The instrumented libtbb must be the one loaded (through the build tree's runpath).
  for t in "${targets[@]/#/tests/}" holoflow; do
    ldd "$tsan/$t" | grep -F "$tbb/prefix/lib/libtbb.so" >/dev/null ||
      { echo "bootstrap: $t does not load the TSan libtbb" >&2; exit 1; }
  done
  # Every report is fatal; tests/tsan.supp may name only reports inside uninstrumented libraries.
  # (CHOLMOD's OpenMP loops run on their caller, kernels/src/cholesky.cpp: an OpenMP team would
  # synchronise inside the uninstrumented libgomp and show up here as a race.)
  # Only the targets built above run (ctest lists the others' tests as <target>_NOT_BUILT; the
  # FuzzReplay tests are plain add_test entries, excluded by name).
  TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$here/tests/tsan.supp" \
    ctest --test-dir "$tsan" -E '_NOT_BUILT$|^FuzzReplay[.]' --output-on-failure -j "$jobs" --timeout 1200 || status=1
  stage_done "the TSan tests"
}

# Debian's onetbb source package into $1 (emptied first), with a deb-src entry for bookworm main
# (/etc/apt/sources.list.d/holoflow-src.sources) added when apt has none.
fetch_tbb_source() {
  if [ "$(id -u)" -ne 0 ]; then
    echo "bootstrap: the TSan stage downloads Debian's onetbb source once; run as root" >&2
    exit 1
  fi
  install_packages dpkg-dev  # dpkg-source unpacks and patches the source package
  apt-get update -q  # the archive keeps only the current source version: index it afresh
  if ! apt-get indextargets --format '$(RELEASE) $(COMPONENT)' 'Created-By: Sources' |
      grep -x 'bookworm main' >/dev/null; then
    printf '%s\n' 'Types: deb-src' 'URIs: http://deb.debian.org/debian' 'Suites: bookworm' 'Components: main' \
      'Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg' >/etc/apt/sources.list.d/holoflow-src.sources
    apt-get update -q
  fi
  rm -rf "$1"
  mkdir -p "$1"
  (cd "$1" && apt-get source -q onetbb)
}

# The test executables are built one per layer in batches of files (tests/CMakeLists.txt,
# HOLOFLOW_TEST_UNITY): a quarter less compile time than one per file when built from scratch.
configure_and_build() {
  configure "$build" -DCMAKE_BUILD_TYPE=Release -DHOLOFLOW_BUILD_TESTS=ON \
    -DHOLOFLOW_BUILD_BENCH=ON -DHOLOFLOW_TEST_UNITY=ON
  cmake --build "$build" -j "$jobs"
}

case "${1:-}" in
  demo)
    install_packages "${packages[@]}"
    configure_and_build
    mesh="${2:-$build/data/meshes/eight.off}"
    "$build/holoflow" info "$mesh"
    "$build/holoflow" segment "$mesh" -o "$build/demo/$(basename "${mesh%.*}")"
    ;;
  test)
    install_packages "${packages[@]}"
    stage_done "installing packages"
    configure_and_build
    stage_done "the Release build"
    # The corpus tests need the libcgal-demo meshes unpacked by the configure step.
    test -f "$build/data/meshes/eight.off" || { echo "bootstrap: libcgal-demo meshes missing" >&2; exit 1; }
    status=0
    ctest --test-dir "$build" --output-on-failure -j "$jobs" --timeout 1200 || status=1
    stage_done "the Release tests"
    # The same suite again under AddressSanitizer and UBSan (leaks on, any UB fatal): hostile
    # inputs must fail cleanly, not by luck of the memory layout. Both runs must pass. The vptr
    # check is recoverable only so that tests/ubsan.supp can let oneTBB's own flow-graph downcast
    # through; halt_on_error keeps every other report fatal. UBSan's null and alignment checks (one
    # on every pointer access) are off: they made the instrumented build 1.5x as long, a null
    # dereference still stops ASan (SEGV, with its stack), and no code here reads bytes through a
    # cast pointer (the binary readers memcpy).
    asan="$build-asan"
    configure "$asan" "${sanitizer_build_flags[@]}" -DHOLOFLOW_BUILD_TESTS=ON -DHOLOFLOW_TEST_UNITY=ON \
      -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize=alignment,null -fno-omit-frame-pointer -fno-sanitize-recover=undefined -fsanitize-recover=vptr" \
      -DHOLOFLOW_BUILD_BENCH=OFF
    cmake --build "$asan" -j "$jobs"
    stage_done "the ASan/UBSan build"
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$here/tests/ubsan.supp" \
      ctest --test-dir "$asan" --output-on-failure -j "$jobs" --timeout 1200 || status=1
    stage_done "the ASan/UBSan tests"
    # The flow-graph tests once more under ThreadSanitizer (see tsan_stage).
    tsan_stage
    [ "$status" -eq 0 ] || echo "bootstrap: the test suite failed (plain or sanitizer build)" >&2
    exit "$status"
    ;;
  tsan)
    install_packages "${packages[@]}"
    status=0
    tsan_stage
    [ "$status" -eq 0 ] || echo "bootstrap: the ThreadSanitizer tests failed" >&2
    exit "$status"
    ;;
  *)
    echo "usage: bash scripts/bootstrap.sh demo [MESH] | test | tsan" >&2
    exit 2
    ;;
esac
