#!/usr/bin/env bash
# Scale-out (issue 16): the synthetic 100 M city (wpd synth -n 100M --seed 1,
# bench/engine.sh's input) to 1 M under --mem 512M with ./wpd on 1 rank x 2
# threads and ./wpd-mpi on 2 ranks x 1 thread, WPD_BENCH_REPEAT pairs
# (default 2) run back to back, then once on 4 ranks x 1 thread (on a 2-core
# machine: oversubscribed, for the traffic). Prints each run's wall time,
# phases, peak RSS of a rank and the bytes the ranks exchanged (--report),
# the median ratio 2 x 1 / 1 x 2 (target <= 1.15) and checks that every
# output is the plain run's bytes. Needs `make MPI=1`; as root mpirun wants
# --allow-run-as-root. WPD_BENCH_MPI_INPUT and WPD_BENCH_MPI_N change the
# cloud and the count.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=bench/out/data
out=bench/out/mpi
mkdir -p "$dir" "$out"
in=${WPD_BENCH_MPI_INPUT:-$dir/city_100000000.las}
n=${WPD_BENCH_MPI_N:-1000000}
repeat=${WPD_BENCH_REPEAT:-2}
[ -x ./wpd-mpi ] || { echo "bench/mpi.sh: build ./wpd-mpi first (make MPI=1)"; exit 1; }
[ -f "$in" ] || ./wpd synth -n 100M --seed 1 -o "$in" >/dev/null
mpirun=(mpirun --oversubscribe)
[ "$(id -u)" = 0 ] && mpirun+=(--allow-run-as-root)

# run NAME RANKS: one run (RANKS 0: the plain ./wpd on 2 threads).
run() {
    local name=$1 ranks=$2 cmd
    if [ "$ranks" = 0 ]; then
        cmd=(./wpd resample "$in" -o "$out/plain.las" --threads 2)
    else
        cmd=("${mpirun[@]}" -np "$ranks" ./wpd-mpi resample "$in" -o "$out/$name.las" --threads 1)
    fi
    cat "$in" >/dev/null
    /usr/bin/time -f "%e" -o "$out/$name.time" "${cmd[@]}" -n "$n" --mem 512M --force -q \
        --tmpdir "$out" --report "$out/$name.json"
    [ "$ranks" = 0 ] || cmp -s "$out/plain.las" "$out/$name.las" ||
        { echo "bench/mpi.sh: $name differs from the plain run"; exit 1; }
    /usr/bin/python3 - "$name" "$(cat "$out/$name.time")" "$out/$name.json" <<'EOF'
import json, sys
name, wall, path = sys.argv[1], float(sys.argv[2]), sys.argv[3]
r = json.load(open(path))
s = r["seconds"]
phases = " ".join("%s %.1f" % (k, s[k]) for k in ("scan", "tile", "poisson", "exact", "smooth",
                                                     "write"))
print("%-10s %6.1f s  %s  rank RSS %d MB  exchanged %d MB (%.2f B a point)  writers %d" % (
    name, wall, phases, r["peak_rss_bytes"] >> 20, r["exchanged_bytes"] >> 20,
    r["exchanged_bytes"] / r["input_points"], r.get("writers", 1)))
EOF
}

ratios=()
for i in $(seq "$repeat"); do
    run "plain_$i" 0
    run "mpi2_$i" 2
    ratios+=("$(echo "$(cat "$out/mpi2_$i.time") / $(cat "$out/plain_$i.time")" | bc -l)")
done
run mpi4 4
printf '%s\n' "${ratios[@]}" | sort -g |
    awk '{a[NR]=$1} END {m = (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2;
         printf "2 ranks x 1 thread / 1 rank x 2 threads: median %.3f (target <= 1.15)\n", m}'
