#!/usr/bin/env bash
# LAZ decode speed: wpd's reader on 1 and 2 threads (build/laz_bench: units
# of whole chunks handed out to the threads as the engine's passes do)
# against LASzip and laz-perf on one core, on the shared LAZ files of point
# formats 1, 3 and 7 with the most points. The machine is noisy:
# LAZ_DECODE_ROUNDS rounds (default 5), each 10 runs per configuration,
# interleaved; the medians of the rounds are printed, and the medians of
# the rounds' ratios (2 threads / 1 thread; wpd / LASzip; wpd / base).
# Two measures on one core: the wall clock (the best of the 10 runs, open
# included) and, where `perf stat` can count task-clock, the CPU time of
# all 10 runs: on a machine shared with other jobs a process also waits to
# be run, which the wall clock counts and the CPU time does not.
# LASzip (laszip_dec, ../shared/tools/laszip: LASzip's C API, one core) is
# measured when build/laszip holds it (`make laszip`); its time includes
# the open, as laz_bench's does.
# laz-perf is measured when LAZPERF_NODE_PATH names a node_modules folder
# holding laz-perf 0.0.7 (default build/npm/node_modules, where `make
# lazperf` installs it; see ../shared/tools/laz2las.js).
# LAZ_BASE names the tree of another build whose build/laz_bench is timed
# in the same rounds, one thread (e.g. `git worktree add /tmp/base COMMIT
# && make -C /tmp/base wpd build/laz_bench`): wpd's speed against it.
set -euo pipefail
cd "$(dirname "$0")/.."
make -s wpd build/laz_bench lazperf laszip
[ -d build/npm/node_modules/laz-perf ] && : "${LAZPERF_NODE_PATH:=build/npm/node_modules}"
base=${LAZ_BASE:-}
if [ -n "$base" ] && [ ! -x "$base/build/laz_bench" ]; then
    echo "LAZ_BASE: no $base/build/laz_bench" >&2
    exit 1
fi
laszip_dec=build/laszip/laszip_dec
[ -x "$laszip_dec" ] || laszip_dec=
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cpu=0
perf stat -e task-clock -x, -o "$dir/perf" true >/dev/null 2>&1 && cpu=1
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
med() { if [ $# -gt 0 ]; then printf '%s\n' "$@" | median; else echo "-"; fi; }
ratio() { echo "scale=3; $1 / $2" | bc; }
# run N CMD...: runs CMD (10 decodes of N points), prints "WALL CPU" in M
# points/s: WALL from CMD's own best run (laz_bench: "... M points/s";
# laszip_dec: N / its best open + loop time), CPU from the task-clock of
# all 10 (- without perf).
run() {
    local n=$1 out wall
    shift
    if [ "$cpu" = 1 ]; then
        out=$(perf stat -e task-clock -x, -o "$dir/perf" "$@")
    else
        out=$("$@")
    fi
    case $out in
        laszip*) wall=$(awk -v n="$n" '{for (i = 1; i < NF; i++) if ($i == "total")
                                         printf "%.3f", n / $(i + 1) / 1e6}' <<<"$out") ;;
        *) wall=$(sed 's/.* \([0-9.]*\) M points\/s$/\1/' <<<"$out") ;;
    esac
    if [ "$cpu" = 1 ]; then
        echo "$wall $(awk -F, -v n="$n" '$3 == "task-clock" {printf "%.3f", 10 * n / $1 / 1e3}' \
                      "$dir/perf")"
    else
        echo "$wall -"
    fi
}
files=(lastools_fusa pdal_autzen_trim pdal_ellipsoid_copc-draft copcvalidator_ellipsoid-1.4)
for f in "${files[@]}"; do
    path=../shared/data/laz/$f.laz
    [ -f "$path" ] || { echo "missing $path"; continue; }
    cat "$path" >/dev/null
    n=$(build/laz_bench "$path" 1 1 | sed 's/^[^:]*: \([0-9]*\) points.*/\1/')
    one=() one_cpu=() two=() ratio=() perf=() lz=() lz_cpu=() vs_lz=() vs_lz_cpu=()
    old=() old_cpu=() vs_old=() vs_old_cpu=()
    for _ in $(seq "${LAZ_DECODE_ROUNDS:-5}"); do
        read -r a a_cpu < <(run "$n" build/laz_bench "$path" 1 10)
        one+=("$a") one_cpu+=("$a_cpu")
        if [ -n "$base" ]; then
            read -r o o_cpu < <(run "$n" "$base/build/laz_bench" "$path" 1 10)
            old+=("$o") vs_old+=("$(ratio "$a" "$o")")
            [ "$cpu" = 1 ] && old_cpu+=("$o_cpu") vs_old_cpu+=("$(ratio "$a_cpu" "$o_cpu")")
        fi
        if [ -n "$laszip_dec" ]; then
            read -r z z_cpu < <(run "$n" "$laszip_dec" "$path" 10)
            lz+=("$z") vs_lz+=("$(ratio "$a" "$z")")
            [ "$cpu" = 1 ] && lz_cpu+=("$z_cpu") vs_lz_cpu+=("$(ratio "$a_cpu" "$z_cpu")")
        fi
        read -r b _ < <(run "$n" build/laz_bench "$path" 2 10)
        two+=("$b") ratio+=("$(ratio "$b" "$a")")
        if [ -n "${LAZPERF_NODE_PATH:-}" ]; then
            perf+=("$(NODE_PATH=$LAZPERF_NODE_PATH node bench/laz_perf.js "$path" |
                      sed 's/.* \([0-9.]*\) M points\/s$/\1/')")
        fi
    done
    [ "$cpu" = 1 ] || one_cpu=()
    echo "laz decode $f ($n points): 1 thread $(med "${one[@]}") M points/s" \
         "(CPU time: $(med "${one_cpu[@]}")), 2 threads $(med "${two[@]}") M points/s" \
         "(ratio $(med "${ratio[@]}")), laz-perf" \
         "$([ ${#perf[@]} -gt 0 ] && echo "$(med "${perf[@]}") M points/s" || echo "not measured")"
    if [ -n "$laszip_dec" ]; then
        echo "  LASzip (laszip_dec, 1 core) $(med "${lz[@]}") M points/s (CPU time:" \
             "$(med "${lz_cpu[@]}")); wpd / LASzip $(med "${vs_lz[@]}") (rounds: ${vs_lz[*]})," \
             "CPU time $(med "${vs_lz_cpu[@]}") (rounds: ${vs_lz_cpu[*]:-})"
    fi
    if [ -n "$base" ]; then
        echo "  base $base $(med "${old[@]}") M points/s (CPU time: $(med "${old_cpu[@]}"));" \
             "wpd / base $(med "${vs_old[@]}") (rounds: ${vs_old[*]})," \
             "CPU time $(med "${vs_old_cpu[@]}") (rounds: ${vs_old_cpu[*]:-})"
    fi
done

# LAZ encode speed (one core: the writer is serial) and size against LAS:
# a synthetic scan (point format 3) converted to .las and to .laz; the
# encode time is the difference, so reading and the LAS writer's own work
# are not counted. LAZ_ENCODE_POINTS sets its size (default 10M; 0 skips it).
n=${LAZ_ENCODE_POINTS:-10M}
if [ "$n" != 0 ]; then
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
fi

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
