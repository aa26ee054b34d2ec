#!/usr/bin/env bash
# One-step set-up on Debian 12 (as root): install the packages, configure, build, then
#   bootstrap.sh demo [MESH]   run the main job on a default model (or MESH)
#   bootstrap.sh test          run the whole test suite (what CI runs)
# Both README commands and .ci/run go through here so that they cannot drift apart.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HOLOFLOW_BUILD_DIR:-$here/build}"
jobs="$(nproc)"

packages=(
  cmake g++ make pkg-config
  libtbb-dev libeigen3-dev libopenmesh-dev
  libsuitesparse-dev libopenblas0-pthread libopenblas-pthread-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev
  libcgal-demo  # real test meshes: /usr/share/doc/libcgal-dev/data.tar.gz
)

install_packages() {
  local missing=()
  for p in "${packages[@]}"; do
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

configure_and_build() {
  cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release -DHOLOFLOW_BUILD_TESTS=ON \
    -DHOLOFLOW_BUILD_BENCH=ON
  cmake --build "$build" -j "$jobs"
}

case "${1:-}" in
  demo)
    install_packages
    configure_and_build
    mesh="${2:-$build/data/meshes/eight.off}"
    "$build/holoflow" info "$mesh"
    "$build/holoflow" segment "$mesh" -o "$build/demo/$(basename "${mesh%.*}")"
    ;;
  test)
    install_packages
    configure_and_build
    # The corpus tests need the libcgal-demo meshes unpacked by the configure step.
    test -f "$build/data/meshes/eight.off" || { echo "bootstrap: libcgal-demo meshes missing" >&2; exit 1; }
    status=0
    ctest --test-dir "$build" --output-on-failure -j "$jobs" --timeout 1200 || status=1
    # The same suite again under AddressSanitizer and UBSan (leaks on, any UB fatal): hostile
    # inputs must fail cleanly, not by luck of the memory layout. Both runs must pass. The vptr
    # check is recoverable only so that tests/ubsan.supp can let oneTBB's own flow-graph downcast
    # through; halt_on_error keeps every other report fatal.
    asan="$build-asan"
    cmake -S "$here" -B "$asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHOLOFLOW_BUILD_TESTS=ON \
      -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined -fsanitize-recover=vptr" \
      -DHOLOFLOW_BUILD_BENCH=OFF
    cmake --build "$asan" -j "$jobs"
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$here/tests/ubsan.supp" \
      ctest --test-dir "$asan" --output-on-failure -j "$jobs" --timeout 1200 || status=1
    [ "$status" -eq 0 ] || echo "bootstrap: the test suite failed (plain or sanitizer build)" >&2
    exit "$status"
    ;;
  *)
    echo "usage: bash scripts/bootstrap.sh demo [MESH] | test" >&2
    exit 2
    ;;
esac
