#!/usr/bin/env bash
# LAZ decode speed (issue 13): wpd's reader on 1 and 2 threads (each
# thread reads an equal share of the points through its own reader, as the
# engine's range reads do) against laz-perf on one core, on the shared LAZ
# files of point formats 1 and 3 with the most points.
# laz-perf is measured when LAZPERF_NODE_PATH names a node_modules folder
# holding laz-perf 0.0.7 (see ../shared/tools/laz2las.js for the setup).
set -euo pipefail
cd "$(dirname "$0")/.."
make -s wpd build/laz_bench
files=(lastools_fusa pdal_autzen_trim pdal_ellipsoid_copc-draft)
for f in "${files[@]}"; do
    path=../shared/data/laz/$f.laz
    [ -f "$path" ] || { echo "missing $path"; continue; }
    cat "$path" >/dev/null
    build/laz_bench "$path" 1
    build/laz_bench "$path" 2
    if [ -n "${LAZPERF_NODE_PATH:-}" ]; then
        NODE_PATH=$LAZPERF_NODE_PATH node bench/laz_perf.js "$path"
    fi
done

# LAZ encode speed (one core: the writer is serial) and size against LAS:
# a synthetic scan (point format 3) converted to .las and to .laz; the
# encode time is the difference, so reading and the LAS writer's own work
# are not counted. LAZ_ENCODE_POINTS sets its size (default 10M).
n=${LAZ_ENCODE_POINTS:-10M}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
./wpd synth -n "$n" -o "$dir/s.las" >/dev/null
cat "$dir/s.las" >/dev/null
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null; t1=$(date +%s.%N); echo "$t1 - $t0" | bc; }
best() { local b=999999 t; for _ in 1 2 3; do t=$(seconds "$@"); b=$(echo "if ($t < $b) $t else $b" | bc); done; echo "$b"; }
t_las=$(best ./wpd convert "$dir/s.las" "$dir/o.las" --force)
t_laz=$(best ./wpd convert "$dir/s.las" "$dir/o.laz" --force)
points=$(./wpd info "$dir/s.las" | awk '/^ *points:/ {print $2}')
las_bytes=$(stat -c %s "$dir/o.las")
laz_bytes=$(stat -c %s "$dir/o.laz")
echo "laz encode: $points points (synth, point format 3); convert to .las ${t_las} s, to .laz ${t_laz} s"
echo "laz encode: $(echo "scale=2; $points / ($t_laz - $t_las) / 1000000" | bc) M points/s (1 core, net of the LAS convert)," \
     "$(echo "scale=2; $points / $t_laz / 1000000" | bc) M points/s end to end"
echo "laz size: $laz_bytes bytes, LAS $las_bytes bytes: $(echo "scale=1; 100 * $laz_bytes / $las_bytes" | bc)% ($(echo "scale=2; $las_bytes / $laz_bytes" | bc)x smaller)"
