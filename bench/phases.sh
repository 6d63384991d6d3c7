#!/usr/bin/env bash
# Per-phase medians of two builds, interleaved: the phase times that
# `wpd resample -v` prints, and the whole command's wall and CPU time,
# for ./wpd and for WPD_BENCH_BASE (another build), each run right after
# the other so both see the same machine. Prints one row per measure:
# medians of this build and of the base, and their ratio (this / base):
# the phases, wall and CPU (user + sys) seconds, peak RSS in MB, and with
# WPD_BENCH_POINTS=N (the input's points) CPU nanoseconds per input point.
# usage: WPD_BENCH_BASE=/path/to/wpd bench/phases.sh RUNS RESAMPLE-ARGS...
# e.g.   WPD_BENCH_BASE=/tmp/wpd_base bench/phases.sh 7 \
#            ../shared/data/scans/nc_raleigh_lidar_2269213.las -n 10000 --threads 2
set -euo pipefail
cd "$(dirname "$0")/.."
base=${WPD_BENCH_BASE:?set WPD_BENCH_BASE to the build to compare with}
runs=$1; shift
out=bench/out/phases
mkdir -p "$out"
one() { # BIN TAG ARGS...: one run; its phase line and CPU times go to TAG's log
    local bin=$1 tag=$2; shift 2
    /usr/bin/time -f "process wall %e cpu %U %S rss %M" "$bin" resample "$@" -o "$out/$tag.las" \
        --force -v 2>&1 | grep -E "^  time:|^process" >>"$out/$tag.log"
}
rm -f "$out"/{new,base}.log
for i in $(seq "$runs"); do
    # Which build runs first alternates (ABBA): the first run of a pair was
    # measured up to 8 % slower in phases neither build changed.
    if ((i % 2)); then
        one ./wpd new "$@"
        one "$base" base "$@"
    else
        one "$base" base "$@"
        one ./wpd new "$@"
    fi
    cmp -s "$out/new.las" "$out/base.las" || echo "phases.sh: the two builds wrote different bytes" >&2
done
/usr/bin/python3 - "$out/new.log" "$out/base.log" <<'PY'
import os, re, statistics, sys
def load(path):
    rows = {}
    for line in open(path):
        if line.startswith("process"):
            w, u, s, m = map(float, re.findall(r"[\d.]+", line))
            pts = float(os.environ.get("WPD_BENCH_POINTS", "0"))
            vals = [("wall", w), ("cpu", u + s), ("sys", s), ("rss MB", m / 1024)]
            if pts:
                vals.append(("cpu ns/point", (u + s) * 1e9 / pts))
            for k, v in vals:
                rows.setdefault("process " + k, []).append(v)
        else:
            for name, v in re.findall(r"([a-z][a-z ]*?) ([\d.]+)(?: s)?(?:,|$| \()", line.split(":", 1)[1]):
                rows.setdefault(name.strip(), []).append(float(v))
    return rows
new, base = load(sys.argv[1]), load(sys.argv[2])
print("%-18s %9s %9s %7s" % ("measure", "this", "base", "ratio"))
for k in new:
    a, b = statistics.median(new[k]), statistics.median(base.get(k, [float("nan")]))
    print("%-18s %9.3f %9.3f %7.3f" % (k, a, b, a / b if b else float("nan")))
PY
