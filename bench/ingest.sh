#!/usr/bin/env bash
# Cron ingestion without seams (docs/ingest.md), measured with bench/ingest.py:
#   1. a synthetic city of WPD_BENCH_INGEST_N points (default 1.8 M) in 3 x 3
#      tiles ingested over 4 nights against one run over all 9 tiles, and the
#      nights each as a cloud of their own (no collection, as before);
#   2. the same with an atypical first night (one tile, the most ground)
#      given --spacing (the one run's radius);
#   3. the same city through tiles (--min-tiles 8: every night and the one
#      run tiled);
#   4. NC Raleigh cut into 2 x 2 tiles at its median x and y, two nights
#      (the diagonal tiles first);
#   5. night 2 against night 4 of a collection 4x larger (one new tile of
#      500 K points touching two old ones each time; medians of 5 runs of
#      each, alternated; wall and CPU time).
# Each prints its figures as JSON into bench/out/ingest/*.json and a line
# per case. The outputs of earlier nights are checked byte for byte after
# every night (sha256).
set -euo pipefail
cd "$(dirname "$0")/.."
out=bench/out/ingest
mkdir -p "$out"
n=${WPD_BENCH_INGEST_N:-1800000}
nc=${WPD_BENCH_NC:-../shared/data/scans/nc_raleigh_lidar_2269213.las}
py=/usr/bin/python3

summary() {
    $py - "$1" <<'PY'
import json, sys
f = json.load(open(sys.argv[1]))
if isinstance(f, list):
    print("  night 2 (3 tiles old) %.2f s wall, %.2f s CPU, %.1f MB; night 4 (12 old) %.2f s, "
          "%.2f s, %.1f MB: wall %.3f, CPU %.3f, peak RSS %.3f" % (
              f[0]["median_seconds"], f[0]["median_cpu_seconds"], f[0]["peak_rss_mb"],
              f[1]["median_seconds"], f[1]["median_cpu_seconds"], f[1]["peak_rss_mb"],
              f[2]["time_ratio"], f[2]["cpu_ratio"], f[2]["rss_ratio"]))
    sys.exit()
print("  closest pair across nights %.4g, inside a night %.4g (one run %.4g); cross-seam "
      "p1 %.4g / one run %.4g = %.4f; Hausdorff %.4f, local CV %.4f of the one run's; "
      "density per night %s" % (
          f["closest_across"], f["closest_within"], f["one_closest"], f["seam_p1"],
          f["one_seam_p1"], f["seam_p1_ratio"], f["hausdorff_ratio"], f["local_cv_ratio"],
          " ".join("%.4f" % d["ratio"] for d in f["density"])))
if "independent" in f:
    g = f["independent"]
    print("  without a collection: closest pair across nights %.4g, cross-seam p1 ratio %.4f, "
          "%d cross-seam pairs closer than r/2" % (g["closest_across"], g["seam_p1_ratio"],
                                                   g["seam_close_pairs"]))
PY
}

case_() {
    local name=$1
    shift
    echo "$name"
    nice -n 5 $py bench/ingest.py "$@" > "$out/$name.json"
    summary "$out/$name.json"
}

case_ grid quality --synth "$n" --independent --work "$out/grid"
case_ atypical quality --synth "$n" --atypical 0 --independent --work "$out/atypical"
case_ grid_tiled quality --synth "$n" --work "$out/grid_tiled" -- --min-tiles 8
if [ -f "$nc" ]; then
    case_ nc quality --scan "$nc" --independent --work "$out/nc"
fi
case_ timing timing --synth 500000 --repeat 5 --work "$out/timing"
