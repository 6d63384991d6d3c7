#!/usr/bin/env bash
# `make demo`: the main job on a built-in example. Generates a synthetic
# city-like LiDAR scan, describes it, resamples it to 20,000 points, measures
# the result and converts it to PLY, printing what each step did. Output goes to build/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
out=build/demo
rm -rf "$out" && mkdir -p "$out"
step() { printf '\n== %s\n$ %s\n' "$1" "${*:2}"; "${@:2}"; }

step "Generate a 200,000-point synthetic city scan (terrain, buildings, trees, 3 flight strips)" \
    ./wpd synth -n 200000 --seed 7 -o "$out/city.las"
step "Describe it" ./wpd info "$out/city.las"
step "Resample it to exactly 20,000 evenly spaced points (every attribute kept)" \
    ./wpd resample "$out/city.las" -o "$out/city_20k.las" -n 20000 --verbose
step "Measure the result against the input" \
    ./wpd metrics "$out/city.las" "$out/city_20k.las"
step "Convert the result to PLY (x y z as double, every LAS dimension kept as a property)" \
    ./wpd convert "$out/city_20k.las" "$out/city_20k.ply"
step "Draw the scan and the result side by side, with their spacing histograms" \
    ./wpd preview "$out/city.las" "$out/city_20k.las" -o "$out/city_before_after.png"
printf '\nDemo files are in %s/ (look at city_before_after.png)\n' "$out"
ls -l "$out"
