#!/usr/bin/env bash
# Spill files of the out-of-core engine (src/spill/): the measurements
# behind its format and defaults.
#  1. Layouts: candidate encodings of the coordinate part (gid, xyz, halo)
#     and of the records, zstd levels -7 .. 3: compressed ratio and
#     single-core compress / decompress MB/s (of raw bytes), on a 20 M point
#     synthetic city scan and on NC Raleigh (real airborne LiDAR), each cut
#     into 64 tiles by an x/y grid, 256 KB chunks.
#  2. The module end to end, 100 M points into 256 tiles: tiling with the
#     compression threads, then 3 coordinate read-backs and one with
#     records on 2 threads.
# Environment: WPD_BENCH_SPILL_LEVELS, WPD_BENCH_SPILL_LAYOUTS narrow step 1.
set -euo pipefail
cd "$(dirname "$0")/.."
make -s build/spill_bench
N=${WPD_BENCH_POINTS:-20000000}
dir=bench/out/data
mkdir -p "$dir"
[ -f "$dir/city_$N.las" ] || ./wpd synth -n "$N" --seed 1 -o "$dir/city_$N.las" >/dev/null
raleigh=../shared/data/scans/nc_raleigh_lidar_2269213.las
files=("$dir/city_$N.las")
[ -f "$raleigh" ] && files+=("$raleigh")
export SPILL_LEVELS=${WPD_BENCH_SPILL_LEVELS:-"-7 -3 -1 1 3"}
[ -n "${WPD_BENCH_SPILL_LAYOUTS:-}" ] && export SPILL_LAYOUTS=$WPD_BENCH_SPILL_LAYOUTS
for f in "${files[@]}"; do
    cat "$f" >/dev/null
    OMP_NUM_THREADS=1 build/spill_bench layouts "$f" 64
    echo
done
unset SPILL_LEVELS SPILL_LAYOUTS
# 100 M points: the synthetic scan 5 times over, NC Raleigh 44 times over
# (gids keep increasing; the coordinates repeat, which the per-chunk codec
# cannot exploit).
tmp=${TMPDIR:-/tmp}
OMP_NUM_THREADS=2 build/spill_bench api "$dir/city_$N.las" 256 $((100000000 / N)) "$tmp"
echo
[ -f "$raleigh" ] && OMP_NUM_THREADS=2 build/spill_bench api "$raleigh" 256 44 "$tmp"
exit 0
