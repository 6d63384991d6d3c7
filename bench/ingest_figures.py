"""The figures of a collection ingested over several nights against one run
over all its tiles (docs/ingest.md): used by bench/ingest.py and by the
slow tests of tests/e2e/test_ingest.py.

tiles:     {name: input path}
nights:    [[names of night 1], [night 2], ...]
coll, one: {name: output path} of the collection and of the one run
r:         the collection's radius

Figures (each for the collection and the one run where it applies):
  closest_within  the closest pair of samples inside any one night's output
                  (the union of the night's tiles)
  closest_across  the closest pair of samples of different nights
  seam_p1         the 1st percentile of cross-seam nearest-neighbour
                  distances: for every sample within 2 r of the border of an
                  adjacent tile of another night, the distance to the
                  nearest sample of that tile (the one run: the same tiles)
  density         per night, samples per unit of xy area of its tiles; the
                  one run's in the same tiles
  hausdorff, local_cv  `wpd metrics` of the union against the inputs' union
"""
import json
import os
import struct
import subprocess

import numpy as np
from scipy.spatial import cKDTree


def las_records(blob):
    """A LAS file's bytes as (header size with VLRs, point format, records
    as an (n, record length) uint8 array, coordinates as an (n, 3) array)."""
    hs, off = struct.unpack_from("<HI", blob, 94)
    pdrf, reclen, legacy = struct.unpack_from("<BHI", blob, 104)
    count = legacy
    if blob[25] >= 4 and hs >= 375:
        count = struct.unpack_from("<Q", blob, 247)[0] or legacy
    scale = np.array(struct.unpack_from("<3d", blob, 131))
    shift = np.array(struct.unpack_from("<3d", blob, 155))
    rec = np.frombuffer(blob, np.uint8, count * reclen, off).reshape(count, reclen)
    return off, pdrf, rec, rec[:, :12].copy().view("<i4").reshape(count, 3) * scale + shift


def las_xyz(path):
    with open(path, "rb") as f:
        return las_records(f.read())[3]


def las_box(path):
    """(min x, min y, max x, max y) of a LAS header."""
    with open(path, "rb") as f:
        b = f.read(227)
    mx, mn, my, mny = struct.unpack_from("<4d", b, 179)
    return mn, mny, mx, my


def adjacent(a, b, tol):
    """Whether two xy boxes share a border (not just a corner)."""
    touch_x = abs(a[2] - b[0]) < tol or abs(b[2] - a[0]) < tol
    touch_y = abs(a[3] - b[1]) < tol or abs(b[3] - a[1]) < tol
    over_x = min(a[2], b[2]) - max(a[0], b[0]) > tol
    over_y = min(a[3], b[3]) - max(a[1], b[1]) > tol
    return (touch_x and over_y) or (touch_y and over_x)


def box_distance(box, p):
    dx = np.maximum(np.maximum(box[0] - p[:, 0], p[:, 0] - box[2]), 0)
    dy = np.maximum(np.maximum(box[1] - p[:, 1], p[:, 1] - box[3]), 0)
    return np.hypot(dx, dy)


def closest_pair(pts):
    if len(pts) < 2:
        return float("inf")
    d, _ = cKDTree(pts).query(pts, 2)
    return float(d[:, 1].min())


def seam_distances(samples, boxes, pairs, r):
    """Cross-seam nearest-neighbour distances over the tile pairs."""
    out = []
    for a, b in pairs:
        for src, dst in ((a, b), (b, a)):
            p = samples[src]
            near = p[box_distance(boxes[dst], p) < 2 * r]
            if len(near) and len(samples[dst]):
                d, _ = cKDTree(samples[dst]).query(near)
                out.append(d)
    return np.concatenate(out) if out else np.zeros(0)


def metrics(wpd, inputs, outputs, work):
    """`wpd metrics --json` of the union of outputs against the inputs'."""
    orig, res = os.path.join(work, "inputs_union.las"), os.path.join(work, "union.las")
    if not os.path.exists(orig):
        subprocess.run([wpd, "convert", "--force", *inputs, orig], check=True,
                       capture_output=True)
    subprocess.run([wpd, "convert", "--force", *outputs, res], check=True, capture_output=True)
    p = subprocess.run([wpd, "metrics", "--json", orig, res], check=True, capture_output=True,
                       text=True)
    m = json.loads(p.stdout)
    os.remove(res)
    return m


def figures(wpd, tiles, nights, coll, one, r, work):
    boxes = {t: las_box(p) for t, p in tiles.items()}
    night_of = {t: k for k, names in enumerate(nights) for t in names}
    cs = {t: las_xyz(p) for t, p in coll.items()}
    os_ = {t: las_xyz(p) for t, p in one.items()}
    tol = 0.05
    pairs = [(a, b) for i, a in enumerate(tiles) for b in list(tiles)[i + 1:]
             if night_of[a] != night_of[b] and adjacent(boxes[a], boxes[b], tol)]
    f = {"r": r, "seams": len(pairs)}
    within = [closest_pair(np.concatenate([cs[t] for t in names])) for names in nights]
    f["closest_within"] = min(within)
    f["closest_within_by_night"] = within
    across = float("inf")
    for k in range(1, len(nights)):
        old = np.concatenate([cs[t] for names in nights[:k] for t in names])
        new = np.concatenate([cs[t] for t in nights[k]])
        d, _ = cKDTree(old).query(new)
        across = min(across, float(d.min()))
    f["closest_across"] = across
    f["one_closest"] = closest_pair(np.concatenate(list(os_.values())))
    dc, do = seam_distances(cs, boxes, pairs, r), seam_distances(os_, boxes, pairs, r)
    f["seam_p1"], f["one_seam_p1"] = float(np.percentile(dc, 1)), float(np.percentile(do, 1))
    f["seam_p1_ratio"] = f["seam_p1"] / f["one_seam_p1"]
    f["seam_close_pairs"] = int((dc < 0.5 * r).sum())
    f["one_seam_close_pairs"] = int((do < 0.5 * r).sum())
    dens = []
    for names in nights:
        area = sum((boxes[t][2] - boxes[t][0]) * (boxes[t][3] - boxes[t][1]) for t in names)
        c = sum(len(cs[t]) for t in names) / area
        o = sum(len(os_[t]) for t in names) / area
        dens.append({"tiles": names, "collection": c, "one": o, "ratio": c / o})
    f["density"] = dens
    mc = metrics(wpd, list(tiles.values()), list(coll.values()), work)
    mo = metrics(wpd, list(tiles.values()), list(one.values()), work)
    for key, path in (("hausdorff", ("hausdorff",)), ("local_cv", ("local_density", "cv"))):
        vc, vo = mc, mo
        for k in path:
            vc, vo = vc[k], vo[k]
        f[key], f["one_" + key], f[key + "_ratio"] = vc, vo, vc / vo
    f["points"] = sum(len(v) for v in cs.values())
    f["one_points"] = sum(len(v) for v in os_.values())
    return f
