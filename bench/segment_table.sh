#!/usr/bin/env bash
# Runs `holoflow segment --json` (layout mode) on corpus meshes and on eight, elephant and
# turbine after 1 and 2 Loop steps, and prints a Markdown table: faces, genus, zeros, patches,
# the conformal stage total, the segmentation stages (zeros, zero fans, tracing, cutting,
# patches), their sum and its ratio to the conformal stage (target: under 0.5).
# Builds nothing. Usage: bench/segment_table.sh [BUILD_DIR]   (default ./build; needs the
# `holoflow` target, and `conformal_bench` for the Loop rows).
set -euo pipefail

build=${1:-./build}
cli="$build/holoflow"
writer="$build/bench/conformal_bench"  # `--write-loop=PATH,LEVEL[,MESH]`
corpus="$build/data/meshes"
meshes=(eight femur elephant helmet anchor couplingdown turbine knot head lion bull)

[[ -x "$cli" ]] || { echo "no $cli: build the holoflow target first" >&2; exit 1; }
[[ -d "$corpus" ]] || { echo "no corpus at $corpus" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

inputs=()
for m in "${meshes[@]}"; do [[ -f "$corpus/$m.off" ]] && inputs+=("$m $corpus/$m.off"); done
if [[ -x "$writer" ]]; then
    for level in 1 2; do
        "$writer" --write-loop="$work/turbine_loop$level.off,$level"
        inputs+=("turbine-loop$level $work/turbine_loop$level.off")
    done
fi

echo "| model | faces | genus | working genus | zeros | patches | flipped uv | conformal ms | zeros | fans | tracing | cutting | patches | segmentation ms | ratio |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for entry in "${inputs[@]}"; do
    label=${entry%% *}
    path=${entry#* }
    "$cli" segment "$path" -o "$work/out" --json > "$work/report.json" 2> "$work/err" || {
        echo "| $label | failed: $(head -1 "$work/err") |"; continue; }
    python3 - "$label" "$work/report.json" <<'PY'
import json, sys
label, path = sys.argv[1], sys.argv[2]
j = json.load(open(path))
t = j["timings_ms"]
seg_stages = ["zeros", "zero_fans", "tracing", "cutting", "patches"]
seg = sum(t.get(s, 0) for s in seg_stages)
conformal = t["total"] - seg - t.get("tip_slicing", 0)
cells = [label, j["faces"], j["genus"], j["working_genus"], j["zero_count"], j["patch_count"],
         j["flipped_uv_triangles"], f"{conformal:.1f}"] + [f"{t.get(s, 0):.1f}" for s in seg_stages] + \
        [f"{seg:.1f}", f"{seg / conformal:.2f}" if conformal > 0 else "-"]
print("| " + " | ".join(str(c) for c in cells) + " |")
PY
done
