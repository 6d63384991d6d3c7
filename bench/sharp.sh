#!/usr/bin/env bash
# --sharp against the same run without it, 2 threads: the 2.27 M-point NC
# Raleigh scan to 100 K in memory and through 16 tiles (--min-tiles 16),
# and, when bench/out/data/nc_7x7.las exists (bench/make_nc_tiled.py: 111 M
# points, 4.2 GB), that cloud to 1 M under --mem 512M. Target: --sharp at
# most 1.3x the time without (docs/algorithm.md section 5, Cost).
# Runs are interleaved (plain, sharp, then the base's sharp run) and each
# case repeated WPD_BENCH_REPEAT times (default 3; 1 for the 111 M cloud
# unless WPD_BENCH_REPEAT_BIG is set). Prints the medians of wall time, CPU
# time (user + sys, /usr/bin/time) and the Poisson phase (--report), the
# ratios sharp / plain, and CPU per input point of the sharp run and of what
# --sharp adds.
# WPD_BENCH_BASE=/path/to/another/wpd runs that binary with --sharp too, each
# of its runs right after this build's, and prints the ratio this / base
# (the machine's speed drifts: only ratios from the same run compare
# builds); on the 111 M cloud only with WPD_BENCH_BASE_BIG=1 (the build
# before labels on demand takes about half an hour there).
set -euo pipefail
cd "$(dirname "$0")/.."
nc=${WPD_BENCH_NC:-../shared/data/scans/nc_raleigh_lidar_2269213.las}
big=${WPD_BENCH_BIG:-bench/out/data/nc_7x7.las}
out=bench/out/sharp
mkdir -p "$out"
[ -f "$nc" ] || { echo "sharp.sh: $nc missing"; exit 1; }
repeat=${WPD_BENCH_REPEAT:-3}
base=${WPD_BENCH_BASE:-}

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }

# one NAME BIN ARGS...: one run; appends "wall cpu poisson rss_kb" to NAME.tsv.
one() {
    local name=$1 bin=$2
    shift 2
    /usr/bin/time -o "$out/$name.time" -f "%e %U %S %M" \
        "$bin" resample "$@" -o "$out/$name.las" --threads 2 --force -q \
        --tmpdir "$out" --report "$out/$name.json"
    read -r wall user sys rss <"$out/$name.time"
    poisson=$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["seconds"]["poisson"])' \
        "$out/$name.json")
    echo "$wall $(echo "$user + $sys" | bc -l) $poisson $rss" >>"$out/$name.tsv"
}

col() { cut -d' ' -f "$2" "$out/$1.tsv" | median; }

# case NAME POINTS REPEATS ARGS...: the runs of one case, then its line.
run_case() {
    local name=$1 points=$2 reps=$3 with_base=$4
    shift 4
    rm -f "$out/${name}_plain.tsv" "$out/${name}_sharp.tsv" "$out/${name}_base.tsv"
    for _ in $(seq "$reps"); do
        one "${name}_plain" ./wpd "$@"
        one "${name}_sharp" ./wpd "$@" --sharp
        [ -z "$with_base" ] || one "${name}_base" "$with_base" "$@" --sharp
    done
    local pw pc pp sw sc sp
    pw=$(col "${name}_plain" 1) pc=$(col "${name}_plain" 2) pp=$(col "${name}_plain" 3)
    sw=$(col "${name}_sharp" 1) sc=$(col "${name}_sharp" 2) sp=$(col "${name}_sharp" 3)
    printf '%-10s plain  wall %7.2f cpu %7.2f poisson %6.2f | sharp wall %7.2f cpu %7.2f poisson %6.2f (peak %d MB)\n' \
        "$name" "$pw" "$pc" "$pp" "$sw" "$sc" "$sp" "$(( $(col "${name}_sharp" 4 | cut -d. -f1) / 1024 ))"
    printf '%-10s sharp / plain: wall %.2fx, cpu %.2fx (target 1.3x); cpu per input point %.2f us sharp, %.2f us added by --sharp\n' \
        "" "$(echo "$sw / $pw" | bc -l)" "$(echo "$sc / $pc" | bc -l)" \
        "$(echo "$sc * 1000000 / $points" | bc -l)" "$(echo "($sc - $pc) * 1000000 / $points" | bc -l)"
    if [ -n "$with_base" ]; then
        local bw bc bp
        bw=$(col "${name}_base" 1) bc=$(col "${name}_base" 2) bp=$(col "${name}_base" 3)
        printf '%-10s base sharp wall %7.2f cpu %7.2f poisson %6.2f; this / base: wall %.3fx, cpu %.3fx\n' \
            "" "$bw" "$bc" "$bp" "$(echo "$sw / $bw" | bc -l)" "$(echo "$sc / $bc" | bc -l)"
    fi
    # (an if, not &&: without a base the last test fails, and set -e would
    # end the script after the first case)
    for v in plain sharp base; do
        if [ -f "$out/${name}_$v.tsv" ]; then
            printf '%-10s   %s runs (wall cpu poisson rss): %s\n' "" "$v" \
                "$(tr '\n' ';' <"$out/${name}_$v.tsv")"
        fi
    done
}

cat "$nc" >/dev/null
run_case nc_mem 2269213 "$repeat" "$base" "$nc" -n 100000
run_case nc_t16 2269213 "$repeat" "$base" "$nc" -n 100000 --min-tiles 16
if [ -f "$big" ]; then
    big_base=$([ "${WPD_BENCH_BASE_BIG:-0}" = 1 ] && echo "$base" || true)
    run_case nc_7x7 111191437 "${WPD_BENCH_REPEAT_BIG:-1}" "$big_base" "$big" -n 1000000 --mem 512M
fi
# What the labels cost: labels computed against the input (the last run).
./wpd resample "$nc" -o "$out/v.las" -n 100000 --sharp --threads 2 --force -v 2>/dev/null |
    grep 'sharp features' | sed 's/^ */nc_mem    /'
