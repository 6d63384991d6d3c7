#!/usr/bin/env bash
# `make demo`: the main job on a built-in example. Generates a synthetic
# city-like LiDAR scan, describes it, and converts it LAS -> PLY -> LAS,
# printing what each step did. Output goes to build/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
out=build/demo
rm -rf "$out" && mkdir -p "$out"
step() { printf '\n== %s\n$ %s\n' "$1" "${*:2}"; "${@:2}"; }

step "Generate a 200,000-point synthetic city scan (terrain, buildings, trees, 3 flight strips)" \
    ./wpd synth -n 200000 --seed 7 -o "$out/city.las"
step "Describe it" ./wpd info "$out/city.las"
step "Convert LAS -> PLY (x y z as double, every LAS dimension kept as a property)" \
    ./wpd convert "$out/city.las" "$out/city.ply"
step "Convert back PLY -> LAS (scale and point format restored)" \
    ./wpd convert "$out/city.ply" "$out/city_back.las"
printf '\nDemo files are in %s/\n' "$out"
ls -l "$out"
