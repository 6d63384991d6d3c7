#!/usr/bin/python3
"""Cron ingestion without seams, measured (docs/ingest.md; bench/ingest.sh
runs the cases).

  ingest.py quality --synth N       a synthetic city of N points in 3 x 3
                                    tiles (`wpd synth --tiles 9`) ingested
                                    over 4 nights, against one run over all
  ingest.py quality --synth N --atypical D
                                    the same with a first night of one tile
                                    (the most ground) given --spacing D
                                    (D <= 0: the one run's radius)
  ingest.py quality --scan FILE     a real scan cut into 2 x 2 tiles,
                                    two nights (diagonal tiles first)
  ingest.py timing --synth N        night 2 and night 4 of a collection that
                                    grew 4 x between them: the same tile
                                    content (copies of one synth tile moved
                                    by their LAS offset), each new tile
                                    touching two old ones

Every run: `wpd resample TILES --per-input DIR -n P% [OPTS]`. Figures on
stdout as JSON (bench/ingest_figures.py says what they are)."""
import argparse
import hashlib
import json
import os
import shutil
import struct
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ingest_figures  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WPD = os.environ.get("WPD_BIN") or os.path.join(REPO, "wpd")


def run(*args):
    p = subprocess.run([WPD, *map(str, args)], capture_output=True, text=True)
    if p.returncode:
        sys.exit("wpd %s -> %d: %s" % (" ".join(map(str, args)), p.returncode, p.stderr))
    return p


def cut_box(src, dst, x0, x1, y0, y1):
    """The points of LAS src with x0 <= x < x1, y0 <= y < y1 into dst, the
    header's counts and bounds made true (as tests/e2e/harness.cut_las)."""
    with open(src, "rb") as f:
        blob = f.read()
    off, pdrf, rec, xyz = ingest_figures.las_records(blob)
    keep = (xyz[:, 0] >= x0) & (xyz[:, 0] < x1) & (xyz[:, 1] >= y0) & (xyz[:, 1] < y1)
    rec, xyz = rec[keep], xyz[keep]
    head = bytearray(blob[:off])
    n = len(rec)
    returns = rec[:, 14] & (0x0F if pdrf >= 6 else 0x07)
    by_return = [int(np.count_nonzero(returns == k)) for k in range(1, 16)]
    if blob[25] >= 4 and struct.unpack_from("<H", blob, 94)[0] >= 375:
        struct.pack_into("<Q15Q", head, 247, n, *by_return)
    ok = pdrf < 6
    struct.pack_into("<I5I", head, 107, n if ok else 0, *(by_return[:5] if ok else [0] * 5))
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    struct.pack_into("<6d", head, 179, hi[0], lo[0], hi[1], lo[1], hi[2], lo[2])
    with open(dst, "wb") as f:
        f.write(head)
        f.write(rec.tobytes())


def synth_tiles(n, work):
    base = os.path.join(work, "city.las")
    run("synth", "-n", n, "--tiles", 9, "-o", base, "--force")
    return {"t%d" % k: os.path.join(work, "city_tile%d.las" % k) for k in range(1, 10)}


def scan_tiles(path, work):
    """Four tiles split at the median x and y of the points (as many
    points left as right, below as above)."""
    xyz = ingest_figures.las_xyz(path)
    xm, ym = float(np.median(xyz[:, 0])), float(np.median(xyz[:, 1]))
    tiles = {}
    for k, (x0, x1, y0, y1) in enumerate([(-1e18, xm, -1e18, ym), (xm, 1e18, -1e18, ym),
                                          (-1e18, xm, ym, 1e18), (xm, 1e18, ym, 1e18)]):
        tiles["q%d" % (k + 1)] = os.path.join(work, "q%d.las" % (k + 1))
        cut_box(path, tiles["q%d" % (k + 1)], x0, x1, y0, y1)
    return tiles


def night(tiles, names, out, opts):
    """One night: the inputs given are every tile so far (the cron line over
    the incoming folder); the collection picks the new ones."""
    t = time.time()
    rep = os.path.join(out, "..", "report.json")
    run("resample", *[tiles[n] for n in names], "--per-input", out, "-q", "--report", rep,
        *opts)
    with open(rep) as f:
        r = json.load(f)
    return time.time() - t, r


def quality(args):
    work = os.path.abspath(args.work)
    os.makedirs(work, exist_ok=True)
    if args.scan:
        tiles = scan_tiles(args.scan, work)
        nights = [["q1", "q4"], ["q2", "q3"]]
    else:
        tiles = synth_tiles(args.synth, work)
        nights = [["t1", "t9"], ["t2", "t4", "t6", "t8"], ["t5"], ["t3", "t7"]]
    opts = ["-n", args.percent, *args.opts]
    one_dir, coll_dir = os.path.join(work, "one"), os.path.join(work, "coll")
    for d in (one_dir, coll_dir):
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
    spacing = []
    _, rone = night(tiles, list(tiles), one_dir, opts)
    if args.atypical is not None:
        first = max(tiles, key=lambda t: ground_share(tiles[t]))
        rest = [t for t in tiles if t != first]
        d = args.atypical if args.atypical > 0 else rone["radius"]
        spacing = ["--spacing", repr(d)]
        shutil.rmtree(one_dir)
        os.makedirs(one_dir)
        _, rone = night(tiles, list(tiles), one_dir, opts + spacing)
        nights = [[first], rest[:3], rest[3:6], rest[6:]]
    given, reports, hashes = [], [], {}
    for names in nights:
        given += names
        secs, r = night(tiles, given, coll_dir, opts + spacing)
        changed = [t for t, h in hashes.items() if sha(os.path.join(coll_dir, t)) != h]
        if changed:
            sys.exit("ingest.py: night %d changed the outputs %s" % (len(reports) + 1, changed))
        hashes.update({os.path.basename(tiles[t]): sha(os.path.join(
            coll_dir, os.path.basename(tiles[t]))) for t in names})
        reports.append({"night": r["collection"]["night"], "seconds": secs,
                        "new_inputs": r["collection"]["new_inputs"],
                        "fixed_samples": r["collection"]["fixed_samples"],
                        "output_points": r["output_points"], "radius": r["radius"],
                        "tiles": r["tiles"]["count"],
                        "peak_rss_mb": r["peak_rss_bytes"] / 1e6})
    coll = {t: os.path.join(coll_dir, os.path.basename(p)) for t, p in tiles.items()}
    one = {t: os.path.join(one_dir, os.path.basename(p)) for t, p in tiles.items()}
    f = ingest_figures.figures(WPD, tiles, nights, coll, one, reports[0]["radius"], work)
    if args.independent:  # the nights as clouds of their own, as before collections
        alone = {}
        for k, names in enumerate(nights):
            d = os.path.join(work, "alone%d" % k)
            shutil.rmtree(d, ignore_errors=True)
            os.makedirs(d)
            night(tiles, names, d, opts + spacing)
            alone.update({t: os.path.join(d, os.path.basename(tiles[t])) for t in names})
        g = ingest_figures.figures(WPD, tiles, nights, alone, one, reports[0]["radius"], work)
        f["independent"] = {k: g[k] for k in ("closest_across", "closest_within", "seam_p1",
                                              "seam_p1_ratio", "seam_close_pairs",
                                              "hausdorff_ratio", "local_cv_ratio")}
    f["nights"] = nights
    f["old_outputs_unchanged"] = True  # checked after every night (sha256)
    f["night_reports"] = reports
    f["one_radius"] = rone["radius"]
    print(json.dumps(f, indent=1))


def sha(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def ground_share(path):
    """Share of class-2 (ground) points of a LAS tile (formats 0-5)."""
    with open(path, "rb") as f:
        b = f.read()
    off = struct.unpack_from("<I", b, 96)[0]
    reclen, n = struct.unpack_from("<HI", b, 105)
    rec = np.frombuffer(b, np.uint8, n * reclen, off).reshape(n, reclen)
    return float(((rec[:, 15] & 31) == 2).mean())


def moved_copy(src, dst, dx, dy):
    """src with every point moved by (dx, dy): its LAS offset and bounds."""
    with open(src, "rb") as f:
        b = bytearray(f.read())
    ox, oy = struct.unpack_from("<2d", b, 155)
    struct.pack_into("<2d", b, 155, ox + dx, oy + dy)
    mx, mn, my, mny = struct.unpack_from("<4d", b, 179)
    struct.pack_into("<4d", b, 179, mx + dx, mn + dx, my + dy, mny + dy)
    with open(dst, "wb") as f:
        f.write(b)


def timed_night(tiles, given, folder, opts):
    """One night: wall seconds, CPU seconds (user + system of the child:
    what a loaded machine inflates least), its report."""
    before = os.times()
    secs, r = night(tiles, given, folder, opts)
    after = os.times()
    cpu = (after.children_user - before.children_user +
           after.children_system - before.children_system)
    return secs, cpu, r


def timing(args):
    """Night 2 (3 tiles old) and night 4 (12 old), each one tile touching
    two old ones: each run args.repeat times from a copy of the folder as
    it was before it, the two alternated so that both see the same load;
    medians."""
    work = os.path.abspath(args.work)
    os.makedirs(work, exist_ok=True)
    src = os.path.join(work, "one_tile.las")
    run("synth", "-n", args.synth, "-o", src, "--force")
    box = ingest_figures.las_box(src)
    w = max(box[2] - box[0], box[3] - box[1]) + 0.01
    tiles = {}
    for i in range(4):
        for j in range(4):
            tiles["c%d%d" % (i, j)] = os.path.join(work, "c%d%d.las" % (i, j))
            moved_copy(src, tiles["c%d%d" % (i, j)], i * w, j * w)
    nights = [["c00", "c10", "c01"], ["c11"],
              ["c20", "c21", "c30", "c31", "c02", "c12", "c03", "c13"], ["c22"]]
    opts = ["-n", args.percent, *args.opts]
    coll = os.path.join(work, "coll")
    shutil.rmtree(coll, ignore_errors=True)
    os.makedirs(coll)
    given, keep = [], {}
    for k, names in enumerate(nights):
        if k in (1, 3):  # the folder as it is before the measured nights
            keep[k] = (coll + ".before%d" % (k + 1), given + names)
            shutil.rmtree(keep[k][0], ignore_errors=True)
            shutil.copytree(coll, keep[k][0])
        given += names
        night(tiles, given, coll, opts)
    runs = {1: [], 3: []}
    for _ in range(args.repeat):
        for k in (1, 3):
            shutil.rmtree(coll)
            shutil.copytree(keep[k][0], coll)
            secs, cpu, r = timed_night(tiles, keep[k][1], coll, opts)
            runs[k].append((secs, cpu, r["peak_rss_bytes"] / 1e6,
                            r["collection"]["fixed_samples"], r["output_points"]))
    out = []
    for k in (1, 3):
        rs = runs[k]
        out.append({"night": k + 1, "old_tiles": len(keep[k][1]) - len(nights[k]),
                    "seconds": [x[0] for x in rs], "cpu_seconds": [x[1] for x in rs],
                    "median_seconds": float(np.median([x[0] for x in rs])),
                    "median_cpu_seconds": float(np.median([x[1] for x in rs])),
                    "peak_rss_mb": float(np.median([x[2] for x in rs])),
                    "fixed_samples": rs[0][3], "output_points": rs[0][4]})
    out.append({"time_ratio": out[1]["median_seconds"] / out[0]["median_seconds"],
                "cpu_ratio": out[1]["median_cpu_seconds"] / out[0]["median_cpu_seconds"],
                "rss_ratio": out[1]["peak_rss_mb"] / out[0]["peak_rss_mb"]})
    print(json.dumps(out, indent=1))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["quality", "timing"])
    ap.add_argument("--synth", type=int, default=0)
    ap.add_argument("--scan")
    ap.add_argument("--atypical", type=float)
    ap.add_argument("--percent", default="10%")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--independent", action="store_true",
                    help="also each night as a cloud of its own (no collection)")
    ap.add_argument("--work", default="bench/out/ingest")
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    args = ap.parse_args(argv[:len(argv) - len(extra) - (1 if extra else 0)])
    args.opts = extra  # more wpd resample options, after --
    (quality if args.what == "quality" else timing)(args)


if __name__ == "__main__":
    main()
