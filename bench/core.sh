#!/usr/bin/env bash
# WPD core speed: the 2.27 M-point NC Raleigh scan to 10 K and 100 K points,
# paper defaults, smoothing on, 2 threads (and 1 for the ratio). The authors'
# release, built from source on this kind of machine, takes about 6 s and
# 14 s (REFERENCE-NOTES.md); the target is 10x faster. Prints the median wall
# time of 5 runs (page cache warm) and the per-step times of the last run.
# WPD_BENCH_BASE=/path/to/another/wpd times that binary too, each of its runs
# right after the corresponding run of ./wpd, and prints its medians and the
# ratio (this build / base) from the same run: only such ratios compare builds
# on a machine whose speed drifts.
set -euo pipefail
cd "$(dirname "$0")/.."
. bench/common.sh
src=${WPD_BENCH_NC:-../shared/data/scans/nc_raleigh_lidar_2269213.las}
[ -f "$src" ] || { echo "core.sh: $src missing"; exit 1; }
out=bench/out/core
mkdir -p "$out"
base=${WPD_BENCH_BASE:-}
printf '%-8s %-8s %10s %10s' target threads median_s target_s
[ -n "$base" ] && printf ' %10s %8s' base_s ratio
echo
for n in 10000 100000; do
    for t in 2 1; do
        args=(resample "$src" -o "$out/nc_$n.las" -n "$n" --threads "$t" --force -q)
        limit=$([ "$n" = 10000 ] && echo 0.6 || echo 1.3)
        limit=$([ "$t" = 2 ] && echo "$limit" || echo -)
        if [ -z "$base" ]; then
            s=$(median_seconds 5 ./wpd "${args[@]}")
            printf '%-8s %-8s %10.3f %10s\n' "$n" "$t" "$s" "$limit"
        else
            read -r s b < <(median_seconds_pair 5 ./wpd "$base" "${args[@]}")
            printf '%-8s %-8s %10.3f %10s %10.3f %8.3f\n' "$n" "$t" "$s" "$limit" "$b" \
                "$(echo "$s / $b" | bc -l)"
        fi
    done
    ./wpd resample "$src" -o "$out/nc_$n.las" -n "$n" --threads 2 --force -v 2>/dev/null | sed 's/^/    /'
done
