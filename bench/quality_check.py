#!/usr/bin/python3
"""bench/quality.sh's criteria without running its baselines again.

    bench/quality_check.py [--wpd BIN] [--seed S] [--threads T] [--jobs J] [--scans A,B]
                           [--options="--iterations 4 ..."]

Runs the wpd rows of bench/quality.sh (`wpd resample IN -o OUT -n N --force
-q`, and with --no-smooth) for every scan and target of
bench/quality_baselines.tsv (the dart and MeshLab rows quality.sh measured:
they do not depend on wpd), measures them with `wpd metrics --json`, and
judges the wpd row by quality.sh's criteria: exact n; local CV and Voronoi
CV the lowest of the rows; Hausdorff within 5 % of the best row; rho >= 0.5.
Prints one line per case and a closing "wpd meets every criterion in N of M
cases"; --json FILE also writes every case's figures. --options adds resample
options to both wpd rows (to try other defaults against the same criteria).
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)


def baselines(path):
    rows = {}
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    keys = lines[0].rstrip("\n").split("\t")
    for line in lines[1:]:
        r = dict(zip(keys, line.rstrip("\n").split("\t")))
        case = (r["scan"], int(r["n"]))
        rows.setdefault(case, []).append(
            {"method": r["method"], "haus": float(r["hausdorff_diag"]),
             "lcv": float(r["local_cv"]), "vcv": float(r["voronoi_cv"]), "rho": float(r["rho"])})
    return rows


def measure(wpd, src, out):
    m = json.loads(subprocess.run([wpd, "metrics", "--json", src, out], capture_output=True,
                                  text=True, check=True).stdout)
    return {"count": m["resampled_points"], "haus": m["hausdorff_rel"],
            "lcv": m["local_density"]["cv"], "vcv": m["voronoi_area"]["cv"],
            "rho": m["poisson_radius"]}


def run_case(args, case, tmp):
    scan, n = case
    src = os.path.join(args.data, scan)
    ext = os.path.splitext(scan)[1]
    rows = {}
    for name, extra in (("wpd", []), ("wpd --no-smooth", ["--no-smooth"])):
        out = os.path.join(tmp, "%s_%d_%s%s" % (scan, n, len(extra), ext))
        subprocess.run([args.wpd, "resample", src, "-o", out, "-n", str(n), "--force", "-q",
                        "--seed", str(args.seed), "--threads", str(args.threads),
                        *args.options.split(), *extra],
                       check=True)
        rows[name] = measure(args.wpd, src, out)
        os.remove(out)
    return rows


def judge(n, wpd_rows, base):
    w = wpd_rows["wpd"]
    others = base + [dict(wpd_rows["wpd --no-smooth"], method="wpd --no-smooth")]
    checks = {
        "exact": w["count"] == n,
        "local_cv": all(w["lcv"] <= o["lcv"] for o in others),
        "voronoi_cv": all(w["vcv"] <= o["vcv"] for o in others),
        "hausdorff": w["haus"] <= 1.05 * min([o["haus"] for o in others] + [w["haus"]]),
        "rho": w["rho"] >= 0.5,
    }
    return checks


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wpd", default=os.path.join(REPO, "wpd"))
    ap.add_argument("--data", default=os.path.join(REPO, "..", "shared", "data", "scans"))
    ap.add_argument("--baselines", default=os.path.join(HERE, "quality_baselines.tsv"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--scans", default="")
    ap.add_argument("--json")
    ap.add_argument("--options", default="")
    args = ap.parse_args()
    base = baselines(args.baselines)
    cases = sorted(base)
    if args.scans:
        cases = [c for c in cases if c[0] in args.scans.split(",")]
    met, results = 0, []
    with tempfile.TemporaryDirectory(prefix="wpd-quality-") as tmp, \
            concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        futures = {c: pool.submit(run_case, args, c, tmp) for c in cases}
        for c in cases:
            rows = futures[c].result()
            checks = judge(c[1], rows, base[c])
            ok = all(checks.values())
            met += ok
            w = rows["wpd"]
            missed = [k for k, v in checks.items() if not v]
            print("%-40s %7d  local %.4f  voronoi %.4f  haus %.5g  rho %.3f  %s" % (
                c[0], c[1], w["lcv"], w["vcv"], w["haus"], w["rho"],
                "yes" if ok else "no: " + ", ".join(missed)))
            sys.stdout.flush()
            results.append({"scan": c[0], "n": c[1], "rows": rows, "checks": checks})
    print("wpd meets every criterion in %d of %d cases (seed %d)" % (met, len(cases), args.seed))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
