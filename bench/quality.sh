#!/usr/bin/env bash
# Resampling quality against two baselines, on every real scan of
# ../shared/data/scans (its MANIFEST.tsv). Not part of `make test` or `make bench`.
# For each scan and each target n (10000 and 10 % of the input's finite
# points, where n is below the input size), four rows:
#   wpd              wpd resample IN -o OUT -n N --force -q
#   wpd --no-smooth  the same, Poisson sample only
#   dart             poisson_dart.py: maximal Poisson-disk sample of the input
#                    points by dart throwing (numpy/scipy); its count is only
#                    within 1 % of n
#   MeshLab exact    meshlab_poisson (meshlabserver "Poisson-disk Sampling",
#                    base mesh subsampling, "Precise sample number"); PLY in
#                    only: LAS is converted with `wpd convert` first. MeshLab
#                    keeps float coordinates, so its input is shifted to the
#                    centre of the bounding box and its output shifted back
#                    (else georeferenced scans lose up to 0.5 m to float
#                    rounding; QUALITY_MESHLAB_SHIFT=0 feeds it unshifted).
# Each output is measured with `wpd metrics --json ORIGINAL OUTPUT`: count,
# symmetric Hausdorff / bbox diagonal, local density (k = 6) CV, Voronoi area
# CV, rho (normalised Poisson radius), d_min; and the wall time of the run
# (one run of the tool's command, page cache warm, I/O and start-up included;
# converting and shifting the MeshLab input are not counted). Best values per (scan, n) are in bold; a
# second table says whether the wpd default row meets: exact n, lowest local
# and Voronoi CV of the rows, Hausdorff within 5 % of the best row, rho >= 0.5.
# A failing run (non-zero exit, timeout, no output) gives a row marked failed.
# Markdown to stdout and to QUALITY_OUT (default bench/out/quality.md);
# progress to stderr.
#
# Environment:
#   WPD_BIN            wpd binary (default ./wpd at the repository root)
#   WPD_METRICS_BIN    wpd used for metrics, info and convert (default WPD_BIN)
#   QUALITY_SCANS      scan file names to run (default: every scan of the manifest)
#   QUALITY_N          targets: numbers and/or percentages (default "10000 10%")
#   QUALITY_DATA       scans directory (default ../shared/data/scans)
#   QUALITY_TOOLS      baseline tools (default ../shared/tools)
#   QUALITY_OUT        markdown file (default bench/out/quality.md)
#   QUALITY_TIMEOUT    seconds before a run is stopped and marked failed (default 3600)
#   QUALITY_NAN        skip (default): scans with NaN points are left out when a
#                      baseline cannot read them; run: try every row anyway
#   QUALITY_MESHLAB_SHIFT  1 (default) or 0, see above
# Example, quick: QUALITY_SCANS=lone-star_tile1.las QUALITY_N=10000 bench/quality.sh
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1
. bench/common.sh

abs() { case $1 in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
wpd=$(abs "${WPD_BIN:-./wpd}")
mwpd=$(abs "${WPD_METRICS_BIN:-$wpd}")
data=${QUALITY_DATA:-../shared/data/scans}
tools=$(abs "${QUALITY_TOOLS:-../shared/tools}")
out_md=${QUALITY_OUT:-bench/out/quality.md}
limit=${QUALITY_TIMEOUT:-3600}
nan_mode=${QUALITY_NAN:-skip}
shift_ml=${QUALITY_MESHLAB_SHIFT:-1}
targets=${QUALITY_N:-"10000 10%"}
py=/usr/bin/python3
reference_output=wpd_conferenceRoom_1_output_2000.ply

log() { echo "quality.sh: $*" >&2; }

for b in "$wpd" "$mwpd"; do
    [ -x "$b" ] || { log "$b missing (make wpd, or set WPD_BIN)"; exit 1; }
done
[ -x "$py" ] || { log "$py missing (apt-get install -y python3)"; exit 1; }
[ -f "$data/MANIFEST.tsv" ] || { log "$data/MANIFEST.tsv missing (QUALITY_DATA)"; exit 1; }
case $nan_mode in skip | run) ;; *) log "QUALITY_NAN must be skip or run"; exit 1 ;; esac

# Baseline prerequisites: missing ones are reported and their rows fail.
dart_missing="" meshlab_missing=""
if ! "$py" -c 'import numpy, scipy.spatial' 2>/dev/null; then
    dart_missing="python3-numpy/python3-scipy missing: apt-get install -y python3-numpy python3-scipy"
fi
[ -f "$tools/baselines/poisson_dart.py" ] || dart_missing="$tools/baselines/poisson_dart.py missing"
for c in meshlabserver xvfb-run xauth; do
    command -v "$c" >/dev/null ||
        meshlab_missing="$c missing: apt-get install -y meshlab xvfb xauth"
done
[ -x "$tools/baselines/meshlab_poisson" ] || meshlab_missing="$tools/baselines/meshlab_poisson missing"
if [ "$shift_ml" = 1 ] && [ -n "$dart_missing" ] && [ -z "$meshlab_missing" ]; then
    meshlab_missing="shifting the MeshLab input needs numpy ($dart_missing; or QUALITY_MESHLAB_SHIFT=0)"
fi
[ -z "$dart_missing" ] || log "dart baseline unavailable: $dart_missing"
[ -z "$meshlab_missing" ] || log "MeshLab baseline unavailable: $meshlab_missing"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/wpd-quality.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/runs" "$tmp/json"
rows=$tmp/rows.tsv    # scan input_points n method status seconds note metrics_json
notes=$tmp/notes.txt  # skipped scans and other remarks for the header
: >"$rows"
: >"$notes"
t_start=$(date +%s.%N)

if [ -n "${QUALITY_SCANS:-}" ]; then
    read -r -a scans <<<"${QUALITY_SCANS//,/ }"
else
    mapfile -t scans < <(awk -F'\t' 'NR > 1 && $1 != "" {print $1}' "$data/MANIFEST.tsv")
fi

# run_timed NAME CMD...: runs CMD under the time limit, stdout and stderr to
# $tmp/runs/NAME.{out,err}; sets run_rc and run_s (wall seconds).
run_timed() {
    local name=$1 t0
    shift
    t0=$(date +%s.%N)
    TMPDIR=$tmp timeout "$limit" "$@" >"$tmp/runs/$name.out" 2>"$tmp/runs/$name.err"
    run_rc=$?
    run_s=$(printf '%.3f' "$(seconds_since "$t0")")
}

# why NAME: one line saying why run NAME failed.
why() {
    local last
    last=$(grep -v '^[[:space:]]*$' "$tmp/runs/$1.err" | tail -n 1 | cut -c1-160 | tr '\t|' '  ')
    case $run_rc in
        124) echo "timed out after ${limit} s" ;;
        0) echo "no output${last:+: $last}" ;;
        *) echo "exit $run_rc${last:+: $last}" ;;
    esac
}

# row SCAN INPUT_POINTS N METHOD NAME OUTPUT: records run NAME (run_rc, run_s)
# and measures OUTPUT against the scan.
row() {
    local scan=$1 np=$2 n=$3 method=$4 name=$5 output=$6
    if [ "$run_rc" -ne 0 ] || [ ! -s "$output" ]; then
        printf '%s\t%s\t%s\t%s\tfailed\t%s\t%s\t-\n' "$scan" "$np" "$n" "$method" "$run_s" \
            "$(why "$name")" >>"$rows"
        log "  $method: FAILED ($(why "$name"))"
        return
    fi
    local js=$tmp/json/$name.json
    if ! "$mwpd" metrics --json "$data/$scan" "$output" >"$js" 2>"$tmp/runs/$name.metrics.err"; then
        printf '%s\t%s\t%s\t%s\tfailed\t%s\tmetrics failed: %s\t-\n' "$scan" "$np" "$n" "$method" \
            "$run_s" "$(tail -n 1 "$tmp/runs/$name.metrics.err" | cut -c1-160 | tr '\t|' '  ')" >>"$rows"
        log "  $method: metrics FAILED"
        return
    fi
    printf '%s\t%s\t%s\t%s\tok\t%s\t\t%s\n' "$scan" "$np" "$n" "$method" "$run_s" "$js" >>"$rows"
    log "  $method: ${run_s} s"
}

# skipped SCAN N METHOD REASON: a row that was not run.
skipped() {
    printf '%s\t%s\t%s\t%s\tfailed\t-\t%s\t-\n' "$1" "$2" "$3" "$4" "$5" >>"$rows"
    log "  $4: not run ($5)"
}

# shift_points MODE IN OUT OFFSET_FILE: MODE in writes IN minus the rounded
# bbox centre (saved in OFFSET_FILE) as float PLY; MODE out writes IN plus the
# saved offset as double PLY.
shift_points() {
    PYTHONPATH=$tools "$py" - "$@" <<'PY'
import sys
import numpy as np
import pcio
mode, src, dst, off_file = sys.argv[1:5]
p = pcio.read_points(src)
if mode == "in":
    off = np.round((p.min(axis=0) + p.max(axis=0)) / 2)
    np.savetxt(off_file, off[None, :], fmt="%.17g")
    pcio.write_ply(dst, p - off, dtype="f4")
else:
    off = np.loadtxt(off_file, ndmin=1)
    pcio.write_ply(dst, p + off, dtype="f8")
PY
}

for scan in "${scans[@]}"; do
    if [ "$scan" = "$reference_output" ]; then
        log "$scan: skipped (reference output of the authors' release, not a scan)"
        continue
    fi
    in=$data/$scan
    if [ ! -f "$in" ]; then
        log "$scan: missing in $data, skipped"
        echo "- $scan: not found in $data, skipped." >>"$notes"
        continue
    fi
    info=$("$mwpd" info --json "$in" 2>/dev/null |
        "$py" -c 'import json,sys; f=json.load(sys.stdin)["files"][0]; print(f["point_count"], f["finite_point_count"])') || {
        log "$scan: wpd info failed, skipped"
        echo "- $scan: \`wpd info\` failed, skipped." >>"$notes"
        continue
    }
    read -r total finite <<<"$info"
    if [ "$finite" -lt "$total" ] && [ "$nan_mode" = skip ]; then
        msg="$scan: skipped: $((total - finite)) of $total points are NaN and the baselines cannot read NaN points (when tried on this file: poisson_dart.py died with a segmentation fault in scipy's cKDTree, meshlabserver had not finished after 12 min of CPU). QUALITY_NAN=run tries them anyway."
        log "$msg"
        echo "- $msg" >>"$notes"
        continue
    fi
    cat "$in" >/dev/null  # page cache warm for the first run, as for the others
    ext=${scan##*.}
    ml_in=""  # MeshLab's input, prepared once per scan
    for t in $targets; do
        case $t in
            *%) n=$((finite * ${t%\%} / 100)) ;;
            *) n=$t ;;
        esac
        if [ "$n" -le 0 ] || [ "$n" -ge "$finite" ]; then
            log "$scan: n = $n ($t) is not below the input's $finite points, skipped"
            continue
        fi
        log "$scan ($finite points) -> $n"
        id=${scan%.*}_$n

        run_timed "${id}_wpd" "$wpd" resample "$in" -o "$tmp/${id}_wpd.$ext" -n "$n" --force -q
        row "$scan" "$finite" "$n" "wpd" "${id}_wpd" "$tmp/${id}_wpd.$ext"
        run_timed "${id}_nosmooth" "$wpd" resample "$in" -o "$tmp/${id}_nosmooth.$ext" -n "$n" \
            --no-smooth --force -q
        row "$scan" "$finite" "$n" "wpd --no-smooth" "${id}_nosmooth" "$tmp/${id}_nosmooth.$ext"

        if [ -n "$dart_missing" ]; then
            skipped "$scan" "$finite" "$n" "dart" "$dart_missing"
        else
            run_timed "${id}_dart" "$py" "$tools/baselines/poisson_dart.py" "$in" "$tmp/${id}_dart.ply" "$n"
            row "$scan" "$finite" "$n" "dart" "${id}_dart" "$tmp/${id}_dart.ply"
        fi

        if [ -n "$meshlab_missing" ]; then
            skipped "$scan" "$finite" "$n" "MeshLab exact" "$meshlab_missing"
        else
            if [ -z "$ml_in" ]; then
                ml_in=$in
                if [ "$ext" != ply ]; then
                    ml_in=$tmp/${scan%.*}_converted.ply
                    "$mwpd" convert --force "$in" "$ml_in" >/dev/null 2>"$tmp/runs/convert.err" ||
                        ml_in="failed: wpd convert: $(tail -n 1 "$tmp/runs/convert.err")"
                fi
                if [ "$shift_ml" = 1 ] && [ "${ml_in#failed}" = "$ml_in" ]; then
                    shift_points in "$ml_in" "$tmp/${scan%.*}_shifted.ply" "$tmp/offset.txt" \
                        2>"$tmp/runs/shift.err" && ml_in=$tmp/${scan%.*}_shifted.ply ||
                        ml_in="failed: shifting the input: $(tail -n 1 "$tmp/runs/shift.err")"
                fi
            fi
            if [ "${ml_in#failed}" != "$ml_in" ]; then
                skipped "$scan" "$finite" "$n" "MeshLab exact" "${ml_in#failed: }"
            else
                ml_out=$tmp/${id}_meshlab.ply
                run_timed "${id}_meshlab" "$tools/baselines/meshlab_poisson" "$ml_in" "$ml_out" "$n" exact
                if [ "$run_rc" -eq 0 ] && [ -s "$ml_out" ] && [ "$shift_ml" = 1 ]; then
                    if shift_points out "$ml_out" "$tmp/${id}_meshlab_back.ply" "$tmp/offset.txt" \
                        2>"$tmp/runs/${id}_meshlab.shift.err"; then
                        mv -f "$tmp/${id}_meshlab_back.ply" "$ml_out"
                    else
                        run_rc=1
                        cp "$tmp/runs/${id}_meshlab.shift.err" "$tmp/runs/${id}_meshlab.err"
                    fi
                fi
                row "$scan" "$finite" "$n" "MeshLab exact" "${id}_meshlab" "$ml_out"
            fi
        fi
        rm -f "$tmp/${id}"_*.*  # outputs measured; keep the disk use small
    done
    rm -f "$tmp/${scan%.*}"_converted.ply "$tmp/${scan%.*}"_shifted.ply
done

total_s=$(printf '%.0f' "$(seconds_since "$t_start")")
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD 2>/dev/null || commit="$commit (with uncommitted changes)"
mkdir -p "$(dirname "$out_md")"
ml_version=$(dpkg-query -W -f='${Version}' meshlab 2>/dev/null || echo unknown)
shift_note=""
[ "$shift_ml" != 1 ] || shift_note=", input shifted to its bbox centre and back (MeshLab keeps float coordinates)"
header="$(date -u '+%Y-%m-%d %H:%M UTC'), commit $commit, wpd binary \`${wpd#"$PWD"/}\`, $(nproc) cores; total run time ${total_s} s.
Baselines: poisson_dart.py (dart throwing on the input points, count within 1 % of n); MeshLab $ml_version Poisson-disk sampling, exact mode$shift_note.
Hausdorff: symmetric, over the input's bounding-box diagonal. CV: coefficient of variation of the local density (k = 6 mean neighbour distance) and of the Voronoi cell areas. rho: normalised Poisson-disk radius (1 = hexagonal packing). d_min: minimum spacing, in the scan's units. time: wall seconds of one run (page cache warm), I/O and start-up included. Bold: best of the rows of that scan and n."
"$py" - "$rows" "$notes" "$header" >"$out_md" <<'PY'
import json, sys
rows_file, notes_file, header = sys.argv[1:4]
print("# Resampling quality (bench/quality.sh)")
print()
print(header)
notes = open(notes_file).read().strip()
if notes:
    print()
    print(notes)

groups = {}
order = []
for line in open(rows_file):
    scan, np_, n, method, status, sec, note, js = line.rstrip("\n").split("\t")
    key = (scan, int(n))
    if key not in groups:
        groups[key] = []
        order.append(key)
    r = dict(scan=scan, points=int(np_), n=int(n), method=method, ok=status == "ok",
             sec=sec, note=note)
    if r["ok"]:
        m = json.load(open(js))
        r.update(count=m["resampled_points"], haus=m["hausdorff_rel"],
                 lcv=m["local_density"]["cv"], vcv=m["voronoi_area"]["cv"],
                 rho=m["poisson_radius"], dmin=m["min_spacing"])
    groups[key].append(r)

def g(v, d=4):
    return "%.*g" % (d, v)

print()
print("| scan | n | method | count | time s | Hausdorff/diag | local CV | Voronoi CV | rho | d_min | note |")
print("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|")
for key in order:
    rs = groups[key]
    ok = [r for r in rs if r["ok"]]
    best = {k: min(r[k] for r in ok) for k in ("haus", "lcv", "vcv")} if ok else {}
    first = True
    for r in rs:
        lead = ("%s (%d) | %d" % (r["scan"], r["points"], r["n"])) if first else " | "
        first = False
        if not r["ok"]:
            print("| %s | %s | failed | %s | | | | | | %s |" % (lead, r["method"], r["sec"], r["note"]))
            continue
        cell = {}
        for k, d in (("haus", 4), ("lcv", 3), ("vcv", 3)):
            cell[k] = g(r[k], d)
            if r[k] == best[k]:
                cell[k] = "**%s**" % cell[k]
        note = r["note"]
        if r["count"] != r["n"]:
            note = ("%+.2f %% of n" % (100.0 * (r["count"] - r["n"]) / r["n"])) + (("; " + note) if note else "")
        print("| %s | %s | %d | %s | %s | %s | %s | %.3f | %s | %s |" % (
            lead, r["method"], r["count"], r["sec"], cell["haus"], cell["lcv"], cell["vcv"],
            r["rho"], g(r["dmin"]), note))

print()
print("wpd default row against the criteria: exact n; local CV and Voronoi CV lowest of the rows"
      " (the rows that ran); Hausdorff within 5 % of the best row; rho >= 0.5.")
print()
print("| scan | n | exact n | local CV lowest | Voronoi CV lowest | Hausdorff <= 1.05 best | rho >= 0.5 | all |")
print("|---|---:|---|---|---|---|---|---|")
met = tried = partial = 0
for key in order:
    rs = groups[key]
    w = [r for r in rs if r["method"] == "wpd"][0]
    ok = [r for r in rs if r["ok"]]
    if not w["ok"]:
        print("| %s | %d | wpd failed | | | | | no |" % key)
        tried += 1
        continue
    others = [r for r in ok if r is not w]
    def lowest(k):
        b = min(others, key=lambda r: r[k]) if others else None
        if b is None or w[k] <= b[k]:
            return True, "yes"
        return False, "no (%s: %s)" % (b["method"], g(b[k], 3))
    c_exact = (w["count"] == w["n"], "yes" if w["count"] == w["n"] else "no (%d)" % w["count"])
    c_l = lowest("lcv")
    c_v = lowest("vcv")
    hb = min(r["haus"] for r in ok)
    ratio = w["haus"] / hb if hb > 0 else 1.0
    c_h = (ratio <= 1.05, "%s (%.2fx)" % ("yes" if ratio <= 1.05 else "no", ratio))
    c_r = (w["rho"] >= 0.5, "%s (%.3f)" % ("yes" if w["rho"] >= 0.5 else "no", w["rho"]))
    allok = all(c[0] for c in (c_exact, c_l, c_v, c_h, c_r))
    tried += 1
    met += allok
    verdict = "**yes**" if allok else "no"
    if len(ok) < len(rs):
        partial += 1
        verdict += " (%d of %d rows ran)" % (len(ok), len(rs))
    print("| %s | %d | %s | %s | %s | %s | %s | %s |" % (key[0], key[1], c_exact[1], c_l[1], c_v[1],
          c_h[1], c_r[1], verdict))
print()
print("wpd default meets every criterion in %d of %d cases%s." % (met, tried,
      " (%d of them with failed rows)" % partial if partial else ""))
PY
cat "$out_md"
log "table written to $out_md (${total_s} s)"
