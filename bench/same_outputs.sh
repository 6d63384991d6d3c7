#!/usr/bin/env bash
# Shows that two builds behave alike: runs a fixed list of commands (every
# command; LAS, LAZ and PLY; in memory and through tiles; classes;
# --per-input; MPI ranks when both builds have a wpd-mpi beside them) with
# each binary in a directory of its own, then compares every file they
# wrote and everything they printed, byte for byte (cmp). For code moves and
# renames, which must change no output.
#
#   bench/same_outputs.sh BASE_WPD [NEW_WPD]     (NEW_WPD defaults to ./wpd)
#
# Prints one line per command and a closing "N commands, N differ"; exits
# non-zero if any output differs.
set -uo pipefail
cd "$(dirname "$0")/.."
base=$(realpath "${1:?usage: bench/same_outputs.sh BASE_WPD [NEW_WPD]}")
new=$(realpath "${2:-./wpd}")
data=${WPD_TEST_DATA:-../shared/data}
data=$(realpath "$data")
out=bench/out/same_outputs
rm -rf "$out" && mkdir -p "$out/inputs"
in=$(realpath "$out/inputs")

# Inputs: synthetic clouds (made by the base build) and real files.
"$base" synth -n 200000 --seed 3 -o "$in/city.las" >/dev/null
"$base" synth -n 60000 --seed 5 --tiles 3 -o "$in/t.las" >/dev/null
"$base" synth -n 100000 --seed 2 --oblique --edge-truth -o "$in/oblique.las" >/dev/null
"$base" convert "$in/city.las" "$in/city.laz" >/dev/null
"$base" convert "$in/city.las" "$in/city.ply" >/dev/null
"$base" convert "$in/city.las" "$in/city_ascii.ply" --ascii >/dev/null
nc=$data/scans/lone-star_tile1.las
lato=$data/scans/meshlab_rangemap_lato270.ply
autzen=$data/las/pdal_autzen_trim_7.las
fusa=$data/laz/lastools_fusa.laz

# One command per line: the arguments after `wpd` ({} is the run's own
# directory, where outputs go).
commands=(
    "info $in/city.las"
    "info --json $in/city.laz $lato $autzen"
    "info --header-only $fusa"
    "convert $in/city.las {}/c.ply"
    "convert $in/city.laz {}/c.las"
    "convert $lato {}/c.laz"
    "convert --ascii $autzen {}/c.ply"
    "synth -n 50000 --seed 9 -o {}/s.las"
    "synth -n 30000 --seed 4 --tiles 2 --oblique --edge-truth -o {}/s.ply"
    "resample $in/city.las -o {}/r.las -n 5000 -q"
    "resample $in/city.las -o {}/r.las -n 5000 -q --min-tiles 8"
    "resample $in/city.las -o r.las -n 3000 -q --min-tiles 4"
    "resample $in/city.laz -o {}/r.las -n 3000 -q --min-tiles 4 --tmpdir {}"
    "resample $in/city.las -o {}/r.laz -n 20000 -q --min-tiles 4 --no-smooth"
    "resample $in/city.laz -o {}/r.ply -n 1% -q --mem 70M"
    "resample $in/city_ascii.ply -o {}/r.ply -n 3000 -q --min-tiles 4"
    "resample $in/city.ply -o {}/r.las -n 4000 -q --threads 1"
    "resample $nc -o {}/r.las -n 10% -q --radius-estimate paper"
    "resample $lato -o {}/r.ply -n 5000 -q --sharp --edge-label --min-tiles 6"
    "resample $in/oblique.las -o {}/r.las -n 4000 -q --sharp --edge-label"
    "resample $in/city.las -o {}/r.las -n 4000 -q --class-count 2=1000 --keep-class 6 --drop-class 7"
    "resample $in/city.las -o {}/r.las -n 4000 -q --class-count 2=1000 --min-tiles 4"
    "resample $autzen -o {}/r.laz -n 3000 -q --min-tiles 4"
    "resample $fusa -o {}/r.las -n 2% -q"
    "resample $in/t_tile1.las $in/t_tile2.las $in/t_tile3.las --per-input {} -n 6000 -q"
    "resample $in/t_tile1.las $in/t_tile2.las $in/t_tile3.las --per-input {} -n 6000 -q --min-tiles 6"
    "resample $in/city.las -o {}/r.las -n 50000 -q --metrics --report {}/r.json"
    "metrics $in/city.las $in/city.ply"
    "metrics --json $nc $lato"
    "edges $in/oblique.las --truth edge_truth -o {}/e.las"
    "preview $in/city.las -o {}/p.png -q"
    "preview $in/city.las $in/city.laz -o {}/p.png -q --label classification"
)
# Run facts that may differ between two runs of one build: times, memory.
volatile='"(seconds|peak_rss_bytes|time|[a-z_]*_s|[a-z_]*seconds)"|time:|peak RSS'
# Report keys of options that were removed (--smooth-mode, --free-surface),
# which an older base build still writes.
removed='s/"smooth_mode": [0-9]+, "keep_on_surface": (true|false), //'

mpi_base=$(dirname "$base")/wpd-mpi mpi_new=$(dirname "$new")/wpd-mpi
if [ -x "$mpi_base" ] && [ -x "$mpi_new" ] && command -v mpirun >/dev/null; then
    commands+=("MPI3 resample $in/city.las -o {}/m.las -n 5000 -q --min-tiles 8"
               "MPI2 resample $in/t_tile1.las $in/t_tile2.las --per-input {} -n 3000 -q")
fi

n=0 differ=0
for k in "${!commands[@]}"; do
    cmd=${commands[$k]}
    for side in base new; do
        dir=$(realpath -m "$out/$k.$side")
        mkdir -p "$dir"
        bin=$base mpi=$mpi_base
        [ "$side" = new ] && bin=$new mpi=$mpi_new
        args=${cmd//\{\}/$dir}
        ranks=
        case $args in MPI*) ranks=${args%% *}; ranks=${ranks#MPI}; args=${args#* } ;; esac
        if [ -n "$ranks" ]; then
            # shellcheck disable=SC2086
            mpirun --allow-run-as-root --oversubscribe -np "$ranks" "$mpi" $args \
                >"$dir.stdout" 2>"$dir.stderr"
        else
            # shellcheck disable=SC2086
            (cd "$dir" && "$bin" $args) >"$dir.stdout" 2>"$dir.stderr"
        fi
        echo "exit $?" >>"$dir.stdout"
        for f in "$dir.stdout" "$dir.stderr" "$dir"/*.json; do
            [ -f "$f" ] || continue
            sed -E -i "s|$dir|{}|g; /$volatile/d; s/[0-9]+\.[0-9]+ s\b/<t> s/g; $removed" "$f"
        done
    done
    n=$((n + 1))
    same=1
    for f in "$out/$k.base.stdout" "$out/$k.base.stderr" $(cd "$out/$k.base" && ls); do
        a=$out/$k.base/$f b=$out/$k.new/$f
        case $f in *.stdout|*.stderr) a=$f b=${f/.base./.new.} ;; esac
        cmp -s "$a" "$b" || { same=0; echo "  differs: ${f##*/}"; }
    done
    [ "$(cd "$out/$k.base" && ls)" = "$(cd "$out/$k.new" && ls)" ] || { same=0; echo "  other files"; }
    if [ $same = 1 ]; then echo "same     wpd $cmd"; else echo "DIFFERS  wpd $cmd"; differ=$((differ + 1)); fi
done
echo "$n commands, $differ differ"
[ "$differ" -eq 0 ]
