#!/usr/bin/env bash
# End to end: `holoflow segment MESH -o DIR --json` on every libcgal-demo mesh
# (<build>/data/meshes/*.off) and, when the folder exists, on the meshes of ../shared/meshes
# (the files its MANIFEST.json lists), each under /usr/bin/time -v and a time limit. Prints a
# Markdown table: input faces, genus, working genus, zeros, patches, stage times from
# segmentation.json `timings_ms` (tip slicing, the conformal stages summed and their solver
# part, each segmentation stage, segmentation stages over conformal ones), their total, the
# process wall time and peak RSS. A mesh the command rejects (non-manifold, several components,
# ...) or that times out gets a `failed:` row.
# Builds nothing. Usage: bench/pipeline_table.sh [BUILD_DIR]   (default ./build; needs the
# `holoflow` target). HOLOFLOW_TIME_LIMIT sets the per-model limit in seconds (default 300).
#
# bench/scaling.sh sources this file for pt_setup, pt_run and pt_table.
set -euo pipefail

# pt_setup BUILD_DIR: checks the tools, sets pt_cli, pt_timer and a work folder pt_work
# (removed on exit).
pt_setup() {
    pt_cli="$1/holoflow"
    [[ -x "$pt_cli" ]] || { echo "no $pt_cli: build the holoflow target first" >&2; exit 1; }
    command -v python3 >/dev/null || { echo "python3 is needed to format the table" >&2; exit 1; }
    command -v timeout >/dev/null || { echo "timeout (coreutils) is needed" >&2; exit 1; }
    pt_timer=/usr/bin/time
    if [[ ! -x "$pt_timer" ]]; then
        echo "note: $pt_timer is missing, so the table has no process wall time and peak RSS" >&2
        pt_timer=""
    fi
    pt_limit=${HOLOFLOW_TIME_LIMIT:-300}
    pt_work=$(mktemp -d)
    trap 'rm -rf "$pt_work"' EXIT
    pt_count=0
}

# pt_run LABEL PATH: `info --json` (for the input face count), then `segment --json` timed;
# results go to $pt_work/N.* and the label to $pt_work/order. Never fails.
pt_run() {
    local label=$1 path=$2 n status=0
    n=$((pt_count += 1))
    echo "running $label" >&2
    timeout "$pt_limit" "$pt_cli" info "$path" --json >"$pt_work/$n.info" 2>/dev/null || true
    # time wraps timeout, so a killed run still reports its peak RSS (the largest descendant's).
    local run=(timeout --kill-after=10 "$pt_limit"
               "$pt_cli" segment "$path" -o "$pt_work/out" --json)
    if [[ -n "$pt_timer" ]]; then
        "$pt_timer" -v -o "$pt_work/$n.time" "${run[@]}" >"$pt_work/$n.json" 2>"$pt_work/$n.err" ||
            status=$?
    else
        "${run[@]}" >"$pt_work/$n.json" 2>"$pt_work/$n.err" || status=$?
    fi
    rm -rf "$pt_work/out"  # outputs of the largest inputs take hundreds of MB
    echo "$status" >"$pt_work/$n.status"
    printf '%s\t%s\n' "$n" "$label" >>"$pt_work/order"
}

# pt_table MODE: prints the table of every pt_run so far; MODE is `corpus` (every stage group)
# or `scaling` (conformal vs segmentation stages, ms per 1k faces, growth exponent between rows).
pt_table() {
    python3 - "$pt_work" "$1" "$pt_limit" <<'PY'
import json, math, os, re, sys

work, mode, limit = sys.argv[1], sys.argv[2], sys.argv[3]
# segmentation.json sorts its keys, so the stage groups come from these lists.
SOLVER = ["analyse", "factorise", "solves"]
SEGMENTATION = ["zeros", "zero_fans", "tracing", "cutting", "patches"]
TIPS = "tip_slicing"


def read(n, ext):
    path = os.path.join(work, "%s.%s" % (n, ext))
    return open(path, errors="replace").read() if os.path.exists(path) else ""


def time_stats(text):
    """Wall ms and peak RSS MB from GNU time -v output (None when absent)."""
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    wall = re.search(r"Elapsed \(wall clock\) time.*?: (?:(\d+):)?(\d+):([\d.]+)", text)
    wall_ms = (1000 * (3600 * int(wall.group(1) or 0) + 60 * int(wall.group(2)) +
                       float(wall.group(3)))) if wall else None
    return wall_ms, (int(rss.group(1)) / 1024 if rss else None)


def failure(n, status):
    if status == 124:
        return "timed out after %s s" % limit
    lines = [l.strip() for l in read(n, "err").splitlines() if l.strip()]
    errors = [l for l in lines if l.startswith("error")]
    if errors:
        return errors[-1]
    signal = re.search(r"Command terminated by signal (\d+)", read(n, "time"))
    if signal or status == 137:  # 137: timeout's KILL, or the kernel's (out of memory)
        return "killed by signal %s" % (signal.group(1) if signal else 9)
    return lines[-1] if lines else "exit status %d" % status


rows = []
for line in open(os.path.join(work, "order")).read().splitlines():
    n, label = line.split("\t", 1)
    status = int(read(n, "status"))
    wall, rss = time_stats(read(n, "time"))
    try:
        faces = json.loads(read(n, "info"))["faces"]
    except (ValueError, KeyError):
        faces = None
    row = {"label": label, "faces": faces, "wall": wall, "rss": rss}
    if status == 0:
        try:
            row["report"] = json.loads(read(n, "json"))
        except ValueError:
            row["error"] = "unreadable segmentation.json"
    else:
        row["error"] = failure(n, status)
    rows.append(row)


def groups(t):
    """Stage times grouped: tips, conformal (every non-segmentation stage), solver part,
    each segmentation stage, segmentation sum (tips included), total."""
    seg = {s: t.get(s, 0.0) for s in SEGMENTATION}
    conformal = sum(v for k, v in t.items() if k not in SEGMENTATION and k not in (TIPS, "total"))
    tips = t.get(TIPS, 0.0)
    return {"tips": tips, "conformal": conformal, "solver": sum(t.get(s, 0.0) for s in SOLVER),
            "seg": seg, "seg_total": tips + sum(seg.values()), "total": t["total"],
            # issue 4's target: segmentation stages (tips left out) under half the conformal ones
            "ratio": "%.2f" % (sum(seg.values()) / conformal) if conformal > 0 else "–"}


def ms(x):
    return "–" if x is None else ("%.1f" % x if x < 100 else "%.0f" % x)


def wall_ms(x):  # GNU time reports wall time in 10 ms steps
    return "–" if x is None else ("<10" if x < 10 else "%.0f" % x)


def count(x):
    return "–" if x is None else str(x)


def emit(head, cells_of):
    print("| " + " | ".join(head) + " |")
    print("|" + "|".join(["---"] + ["---:"] * (len(head) - 1)) + "|")
    previous = None
    for r in rows:
        if "error" in r:
            cells = [r["label"], count(r["faces"]), "failed: " + r["error"].replace("|", "/")]
            print("| " + " | ".join(cells) + " |" + " |" * (len(head) - len(cells)))
            continue
        cells, previous = cells_of(r, previous)
        print("| " + " | ".join(cells) + " |")


if mode == "corpus":
    head = ["model", "faces", "genus", "working genus", "zeros", "patches", "tips ms",
            "conformal ms", "(solver ms)", "zeros ms", "fans ms", "tracing ms", "cutting ms",
            "patches ms", "seg / conformal", "total ms", "process wall ms", "peak RSS MB"]

    def cells_of(r, previous):
        j, g = r["report"], groups(r["report"]["timings_ms"])
        return ([r["label"], count(r["faces"]), str(j["genus"]), str(j["working_genus"]),
                 str(j["zero_count"]), str(j["patch_count"]),
                 ms(g["tips"]) if TIPS in j["timings_ms"] else "–",
                 ms(g["conformal"]), ms(g["solver"])] +
                [ms(g["seg"][s]) for s in SEGMENTATION] +
                [g["ratio"], ms(g["total"]), wall_ms(r["wall"]), ms(r["rss"])]), previous
else:
    # Growth exponent between consecutive rows: log(time ratio) / log(face ratio); 1 is linear.
    head = ["model", "faces", "zeros", "patches", "conformal ms", "(solver ms)", "zeros ms",
            "fans ms", "tracing ms", "cutting ms", "patches ms", "segmentation ms", "seg / conformal", "total ms",
            "ms per 1k faces", "exponent", "process wall ms", "peak RSS MB", "RSS KB per face"]

    def cells_of(r, previous):
        j, g = r["report"], groups(r["report"]["timings_ms"])
        f, total = r["faces"], g["total"]
        exponent = "–"
        if previous and f and previous[0] and f != previous[0] and previous[1] > 0 and total > 0:
            exponent = "%.2f" % (math.log(total / previous[1]) / math.log(f / previous[0]))
        cells = [r["label"], count(f), str(j["zero_count"]), str(j["patch_count"]),
                 ms(g["conformal"]), ms(g["solver"])] + [ms(g["seg"][s]) for s in SEGMENTATION] + [
                 ms(g["seg_total"]), g["ratio"], ms(total),
                 "%.2f" % (1000 * total / f) if f else "–", exponent, wall_ms(r["wall"]),
                 ms(r["rss"]), "%.2f" % (1024 * r["rss"] / f) if f and r["rss"] else "–"]
        return cells, (f, total)

emit(head, cells_of)
PY
}

# The meshes of the shared folder: its MANIFEST.json's files, else every mesh-format file.
pt_shared_meshes() {
    python3 - "$1" <<'PY'
import glob, json, os, sys
folder = sys.argv[1]
try:
    files = [e["file"] for e in json.load(open(os.path.join(folder, "MANIFEST.json")))]
except (OSError, ValueError, KeyError, TypeError):
    files = [os.path.basename(p) for p in glob.glob(os.path.join(folder, "*"))
             if p.lower().endswith((".off", ".obj", ".ply", ".stl"))]
for f in sorted(files, key=str.lower):
    if os.path.isfile(os.path.join(folder, f)):
        print(f)
PY
}

pt_main() {
    local build=${1:-./build}
    local corpus="$build/data/meshes"
    local shared
    shared="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/../shared/meshes"
    if [[ ! -d "$corpus" ]]; then
        echo "no corpus at $corpus (configure with libcgal-demo installed)" >&2
        exit 1
    fi
    pt_setup "$build"
    local path file
    for path in "$corpus"/*.off; do pt_run "$(basename "$path" .off)" "$path"; done
    if [[ -d "$shared" ]]; then
        while IFS= read -r file; do
            pt_run "shared/$file" "$shared/$file"
        done < <(pt_shared_meshes "$shared")
    else
        echo "skip the shared meshes: no $shared" >&2
    fi
    echo "Stage columns and total: ms from segmentation.json \`timings_ms\`; conformal sums" \
         "its stages (solver: analyse + factorise + solves); process wall: the whole command" \
         "(load, stages, writing the outputs), 10 ms resolution. Per-model limit ${pt_limit} s."
    echo
    pt_table corpus
}

if [[ "${BASH_SOURCE[0]}" == "$0" ]]; then pt_main "$@"; fi
