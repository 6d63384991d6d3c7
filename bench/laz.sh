#!/usr/bin/env bash
# LAZ decode speed (issue 13): wpd's reader on 1 and 2 threads (build/
# laz_bench: units of whole chunks handed out to the threads as the
# engine's passes do) against laz-perf on one core, on the shared LAZ files
# of point formats 1, 3 and 7 with the most points. The machine is noisy:
# LAZ_DECODE_ROUNDS rounds (default 5), each the best of 10 runs per
# configuration, interleaved; the medians are printed, and the median of
# the rounds' 2-thread / 1-thread ratios.
# laz-perf is measured when LAZPERF_NODE_PATH names a node_modules folder
# holding laz-perf 0.0.7 (default build/npm/node_modules, where `make
# lazperf` installs it; see ../shared/tools/laz2las.js).
set -euo pipefail
cd "$(dirname "$0")/.."
make -s wpd build/laz_bench lazperf
[ -d build/npm/node_modules/laz-perf ] && : "${LAZPERF_NODE_PATH:=build/npm/node_modules}"
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
rate() { sed 's/.* \([0-9.]*\) M points\/s$/\1/'; }
files=(lastools_fusa pdal_autzen_trim pdal_ellipsoid_copc-draft copcvalidator_ellipsoid-1.4)
for f in "${files[@]}"; do
    path=../shared/data/laz/$f.laz
    [ -f "$path" ] || { echo "missing $path"; continue; }
    cat "$path" >/dev/null
    one=() two=() ratio=() perf=()
    for _ in $(seq "${LAZ_DECODE_ROUNDS:-5}"); do
        a=$(build/laz_bench "$path" 1 10 | rate)
        b=$(build/laz_bench "$path" 2 10 | rate)
        one+=("$a") two+=("$b") ratio+=("$(echo "scale=3; $b / $a" | bc)")
        if [ -n "${LAZPERF_NODE_PATH:-}" ]; then
            perf+=("$(NODE_PATH=$LAZPERF_NODE_PATH node bench/laz_perf.js "$path" | rate)")
        fi
    done
    echo "laz decode $f: 1 thread $(printf '%s\n' "${one[@]}" | median) M points/s," \
         "2 threads $(printf '%s\n' "${two[@]}" | median) M points/s" \
         "(ratio $(printf '%s\n' "${ratio[@]}" | median))," \
         "laz-perf $([ ${#perf[@]} -gt 0 ] && echo "$(printf '%s\n' "${perf[@]}" | median) M points/s" || echo "not measured")"
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

# End to end (issue 13): `wpd synth` points to 1 % under --mem 512M on 2
# threads, from the LAS file and from its LAZ copy, and one parallel decode of
# the LAZ (laz_bench, 2 threads), medians of LAZ_E2E_REPEAT runs (default 3)
# each, interleaved, all in this run; for point format 3 (the point-wise
# compressor) and 7 (the layered one: bench/make_format7.py carries every
# attribute over). Target: the LAZ run at most the LAS run plus 1.2 decodes.
# LAZ_E2E_POINTS sets the size (default 100000000; 0 skips it: the files
# take 3.4 + 3.6 GB as LAS and 0.75 + 0.73 GB as LAZ).
e2e=${LAZ_E2E_POINTS:-100000000}
# e2e_case NAME LAS LAZ
e2e_case() {
    local name=$1 las=$2 laz=$3 out=bench/out/laz kind in
    mkdir -p "$out"
    : >"$out/$name.las.t"; : >"$out/$name.laz.t"; : >"$out/$name.decode.t"
    for _ in $(seq "${LAZ_E2E_REPEAT:-3}"); do
        for kind in las laz; do
            in=$las; [ $kind = laz ] && in=$laz
            cat "$in" >/dev/null
            /usr/bin/time -f "%e %M" -o "$out/$kind.time" ./wpd resample "$in" -o "$out/o.las" \
                -n $((e2e / 100)) --mem 512M --threads 2 --force -q --tmpdir "$out" \
                --report "$out/$name.$kind.json"
            cat "$out/$kind.time" >>"$out/$name.$kind.t"
        done
        build/laz_bench "$laz" 2 1 | sed 's/.*: \([0-9.]*\) s, .*/\1/' >>"$out/$name.decode.t"
    done
    local t_las t_laz t_dec
    t_las=$(cut -d' ' -f1 "$out/$name.las.t" | median)
    t_laz=$(cut -d' ' -f1 "$out/$name.laz.t" | median)
    t_dec=$(median <"$out/$name.decode.t")
    echo "end to end, $name, $e2e points to 1 % (--mem 512M, 2 threads), medians:" \
         "from LAS $t_las s ($(( $(cut -d' ' -f2 "$out/$name.las.t" | median | cut -d. -f1) / 1024 )) MB)," \
         "from LAZ $t_laz s ($(( $(cut -d' ' -f2 "$out/$name.laz.t" | median | cut -d. -f1) / 1024 )) MB)," \
         "one parallel decode $t_dec s"
    echo "  LAZ - LAS = $(echo "$t_laz - $t_las" | bc) s = $(echo "scale=2; ($t_laz - $t_las) / $t_dec" | bc)" \
         "decodes (target <= 1.2)"
}
if [ "$e2e" != 0 ]; then
    data=bench/out/data
    mkdir -p "$data"
    las=$data/city_$e2e.las laz=$data/city_$e2e.laz las7=$data/city7_$e2e.las laz7=$data/city7_$e2e.laz
    [ -f "$las" ] || ./wpd synth -n "$e2e" --seed 1 -o "$las" >/dev/null
    [ -f "$laz" ] || ./wpd convert "$las" "$laz" >/dev/null
    [ -f "$las7" ] || /usr/bin/python3 bench/make_format7.py "$las" "$las7"
    [ -f "$laz7" ] || ./wpd convert "$las7" "$laz7" >/dev/null
    e2e_case format3 "$las" "$laz"
    e2e_case format7 "$las7" "$laz7"
fi
