#!/usr/bin/env bash
# Runs `holoflow conformal --json` on the corpus meshes with genus > 0 or boundaries, plus turbine
# after 1 and 2 Loop steps, and prints a Markdown table: faces, genus, the stage timings the
# pipeline reports, their total, the process wall time and its peak RSS (from /usr/bin/time -v).
# Builds nothing. Usage: bench/conformal_table.sh [BUILD_DIR]   (default ./build; needs the
# `holoflow` and `kernels_bench` targets built, the latter only for the Loop rows).
set -euo pipefail

build=${1:-./build}
cli="$build/holoflow"
writer="$build/bench/kernels_bench"  # `--write-subdivided=PATH,MESH,SCHEME,LEVEL` writes the Loop levels
corpus="$build/data/meshes"
meshes=(eight femur elephant helmet anchor couplingdown turbine knot rotor head lion
        mech-holes-shark cheese)
loop_levels=(1 2)

[[ -x "$cli" ]] || { echo "no $cli: build the holoflow target first" >&2; exit 1; }
[[ -d "$corpus" ]] || { echo "no corpus at $corpus (configure with libcgal-demo installed)" >&2; exit 1; }
command -v python3 >/dev/null || { echo "python3 is needed to format the table" >&2; exit 1; }

timer=/usr/bin/time
if [[ ! -x "$timer" ]]; then
    echo "note: $timer is missing, so the table has no peak RSS (GNU time is not installed)" >&2
    timer=""
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

inputs=()   # "label path" pairs, in table order
for m in "${meshes[@]}"; do
    if [[ -f "$corpus/$m.off" ]]; then inputs+=("$m $corpus/$m.off"); else echo "skip $m: not in corpus" >&2; fi
done
if [[ -x "$writer" && -f "$corpus/turbine.off" ]]; then
    for level in "${loop_levels[@]}"; do
        "$writer" --write-subdivided="$work/turbine_loop$level.off,turbine,loop,$level"
        inputs+=("turbine-loop$level $work/turbine_loop$level.off")
    done
else
    echo "skip the turbine Loop rows: build the kernels_bench target (HOLOFLOW_BUILD_BENCH=ON)" >&2
fi

for entry in "${inputs[@]}"; do
    label=${entry%% *} path=${entry#* }
    echo "running $label" >&2
    status=0
    if [[ -n "$timer" ]]; then
        "$timer" -v -o "$work/$label.time" "$cli" conformal "$path" -o "$work/out" --json \
            >"$work/$label.json" 2>"$work/$label.err" || status=$?
    else
        "$cli" conformal "$path" -o "$work/out" --json >"$work/$label.json" \
            2>"$work/$label.err" || status=$?
    fi
    echo "$status" >"$work/$label.status"
    echo "$label" >>"$work/order"
done

python3 - "$work" <<'PY'
import json, os, re, sys

work = sys.argv[1]
order = open(os.path.join(work, "order")).read().split()
# The pipeline's stage order (conformal.json keeps keys sorted); unknown stages go last.
known = ["double_cover", "intrinsic_delaunay", "laplacian_assembly",
         "cut_graph_and_closed_forms", "wedge_matrix", "carry_forms", "analyse", "factorise",
         "overlap", "solves", "hodge_star", "holomorphic_basis", "integration"]

rows, stages = [], []
for label in order:
    status = int(open(os.path.join(work, label + ".status")).read())
    rss, wall = None, None
    tpath = os.path.join(work, label + ".time")
    if os.path.exists(tpath):
        text = open(tpath).read()
        m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
        rss = int(m.group(1)) / 1024 if m else None
        m = re.search(r"Elapsed \(wall clock\) time.*?: (?:(\d+):)?(\d+):([\d.]+)", text)
        if m:
            wall = 1000 * (3600 * int(m.group(1) or 0) + 60 * int(m.group(2)) + float(m.group(3)))
    report = None
    if status == 0:
        report = json.load(open(os.path.join(work, label + ".json")))
        for s in report["timings_ms"]:
            if s != "total" and s not in stages:
                stages.append(s)
    else:
        err = open(os.path.join(work, label + ".err")).read().strip().splitlines()
        report = {"error": err[-1] if err else "exit status %d" % status}
    rows.append((label, report, rss, wall))

stages.sort(key=lambda s: (known.index(s) if s in known else len(known), s))
fmt = lambda x: "–" if x is None else ("%.1f" % x if x < 100 else "%.0f" % x)
# GNU time reports wall time in 10 ms steps.
fmt_wall = lambda x: "–" if x is None else ("<10" if x < 10 else "%.0f" % x)
head = (["mesh", "faces", "worked faces", "genus", "working genus"] + stages +
        ["total ms", "process wall ms", "peak RSS MB"])
print("Stage columns and total: milliseconds from conformal.json `timings_ms` (compute_conformal "
      "only); process wall: the whole CLI run (load, stage, writing uv.obj and forms).\n")
print("| " + " | ".join(head) + " |")
print("|" + "|".join(["---"] + ["---:"] * (len(head) - 1)) + "|")
for label, r, rss, wall in rows:
    if "error" in r:
        print("| %s | failed: %s |%s" % (label, r["error"].replace("|", "/"), " |" * (len(head) - 2)))
        continue
    faces = r["faces"] // 2 if r["double_covered"] else r["faces"]
    t = r["timings_ms"]
    cells = [label, str(faces), str(r["faces"]) + (" (cover)" if r["double_covered"] else ""),
             str(r["genus"]), str(r["working_genus"])]
    cells += [fmt(t.get(s)) for s in stages] + [fmt(t["total"]), fmt_wall(wall), fmt(rss)]
    print("| " + " | ".join(cells) + " |")
PY
