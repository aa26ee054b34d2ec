#!/usr/bin/env bash
# Scaling of `holoflow segment --json` with mesh size: one corpus mesh under repeated
# subdivision (default eight, genus 2, 634 faces, Loop levels 2 to 6: 10.1k to 2.6M faces; the
# surface and its zeros stay the same, only the resolution grows), each level under
# /usr/bin/time -v. Prints a Markdown table: faces, zeros, patches, the conformal stages summed
# (and their solver part), each segmentation stage and their sum, the total, ms per 1k faces, the
# growth exponent log(total ratio) / log(faces ratio) against the previous row (1 = linear),
# the process wall time and peak RSS (also per face).
# Builds nothing. Needs the `holoflow` and `kernels_bench` targets (the latter writes the
# levels: `kernels_bench --write-subdivided=PATH,MESH,SCHEME,LEVEL`).
# Usage: bench/scaling.sh [BUILD_DIR] [--mesh NAME|FILE] [--scheme loop|midpoint]
#                         [--min-level N] [--max-level N]
# The default run takes about 30 s on a quiet 2-core machine and peaks at 2.3 GB (level 6); each
# further level takes 4 to 7 times as long and 4 times the memory, so --max-level 7 needs ~10 GB.
# HOLOFLOW_TIME_LIMIT: per-level limit in seconds (default 600).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=pipeline_table.sh
source "$here/pipeline_table.sh"

build=./build
mesh=eight
scheme=loop
min_level=2
max_level=6
if [[ $# -gt 0 && $1 != --* ]]; then build=$1; shift; fi
while [[ $# -gt 0 ]]; do
    case $1 in
        --mesh) mesh=${2:?--mesh needs a value}; shift 2 ;;
        --scheme) scheme=${2:?--scheme needs a value}; shift 2 ;;
        --min-level) min_level=${2:?--min-level needs a value}; shift 2 ;;
        --max-level) max_level=${2:?--max-level needs a value}; shift 2 ;;
        *) echo "usage: $0 [BUILD_DIR] [--mesh NAME|FILE] [--scheme loop|midpoint]" \
                "[--min-level N] [--max-level N]" >&2; exit 2 ;;
    esac
done

writer="$build/bench/kernels_bench"
if [[ ! -x "$writer" ]]; then
    echo "no $writer: build the kernels_bench target (HOLOFLOW_BUILD_BENCH=ON)" >&2
    exit 1
fi
export HOLOFLOW_TIME_LIMIT=${HOLOFLOW_TIME_LIMIT:-600}
pt_setup "$build"

name=$(basename "$mesh")
name=${name%.*}
for ((level = min_level; level <= max_level; ++level)); do
    input="$pt_work/${name}_${scheme}$level.off"
    "$writer" --write-subdivided="$input,$mesh,$scheme,$level" >/dev/null
    pt_run "$name $scheme $level" "$input"
    rm -f "$input"  # the largest levels are hundreds of MB of text
done

echo "$name after $scheme subdivision, levels $min_level to $max_level. Stage times: ms from" \
     "segmentation.json \`timings_ms\` (conformal: its stages summed; segmentation: tip slicing" \
     "if any, zeros, fans, tracing, cutting, patches); exponent: log(total ratio) /" \
     "log(faces ratio) against the row above (1 = linear); process wall includes loading and" \
     "writing the outputs."
echo
pt_table scaling
