#!/usr/bin/env bash
# Reader throughput, one thread, page cache warm: `wpd info` streams every
# point and computes the bounds. Targets: binary LAS and binary PLY >= 100 M
# points/s, ascii PLY >= 5 M points/s.
set -euo pipefail
cd "$(dirname "$0")/.."
. bench/common.sh
N=${WPD_BENCH_POINTS:-20000000}
NA=${WPD_BENCH_ASCII_POINTS:-5000000}
dir=bench/out/data
mkdir -p "$dir"
[ -f "$dir/city_$N.las" ] || ./wpd synth -n "$N" --seed 1 -o "$dir/city_$N.las" >/dev/null
[ -f "$dir/city_$N.ply" ] || ./wpd convert "$dir/city_$N.las" "$dir/city_$N.ply" >/dev/null
# Two ascii files: a typical scanner/CloudCompare export (float xyz, rgb,
# normals) and LAS-derived doubles written by wpd (17-digit GPS times).
[ -f "$dir/scanner_${NA}_ascii.ply" ] ||
    /usr/bin/python3 bench/make_ascii_ply.py "$NA" "$dir/scanner_${NA}_ascii.ply"
[ -f "$dir/city_${NA}_ascii.ply" ] ||
    ./wpd synth -n "$NA" --seed 1 -o "$dir/city_${NA}_ascii.ply" --ascii >/dev/null
export OMP_NUM_THREADS=1
printf '%-28s %12s %12s %10s %14s\n' file points bytes median_s Mpoints_per_s
for f in "$dir/city_$N.las" "$dir/city_$N.ply" "$dir/scanner_${NA}_ascii.ply" \
    "$dir/city_${NA}_ascii.ply"; do
    n=$(./wpd info --json "$f" | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["files"][0]["finite_point_count"])')
    t=$(median_seconds 5 ./wpd info --json "$f")
    printf '%-28s %12d %12d %10.3f %14.1f\n' "$(basename "$f")" "$n" "$(stat -c %s "$f")" "$t" \
        "$(echo "$n / $t / 1000000" | bc -l)"
done
