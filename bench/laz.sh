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
