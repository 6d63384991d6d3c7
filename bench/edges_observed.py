#!/usr/bin/python3
"""How much of `wpd synth --edge-truth`'s truth the survey lets a detector see:
for each truth point, whether both faces of its crease carry input points
within R of it (default 1.8 m: the detector's reach of 5 spacings). Faces
(the creases are axis-aligned):
 1 ridge     roof points (class 6) on both sides of it in x or in y
 2 wall top  roof points at its height or above, and wall points below it
             (more than 0.4 m lower, within 0.4 m of its x or y)
 3 corner    wall points on the wall along x and on the wall along y
 4 foot      ground points (class 2), and wall points above it
A face "carries points" with 3 or more. Usage: edges_observed.py CLOUD.las [R]"""
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 2)[0] + "/tests/e2e")
from formats import read_las  # noqa: E402


def field(h, off, t):
    rec = np.frombuffer(h["points"], np.uint8).reshape(-1, h["record_length"])
    return rec[:, off:off + np.dtype(t).itemsize].copy().view("<" + t).ravel()


def main():
    h = read_las(sys.argv[1])
    R = float(sys.argv[2]) if len(sys.argv) > 2 else 1.8
    rl = h["record_length"]
    rec = np.frombuffer(h["points"], np.uint8).reshape(-1, rl)
    xyz = rec[:, :12].copy().view("<i4").reshape(-1, 3) * np.array(h["scale"])
    cls = rec[:, 15] & 31
    truth = rec[:, rl - 1]          # edge_truth: the last extra byte
    cell = np.floor(xyz[:, :2] / R).astype(np.int64)
    key = cell[:, 0] * 1000003 + cell[:, 1]
    order = np.argsort(key, kind="stable")
    skey = key[order]
    kinds = {1: "ridge", 2: "wall top", 3: "corner", 4: "foot"}
    seen = {k: [0, 0] for k in kinds}
    for i in np.flatnonzero(truth):
        k = int(truth[i])
        idx = []
        for a in (-1, 0, 1):
            for b in (-1, 0, 1):
                kk = (cell[i, 0] + a) * 1000003 + cell[i, 1] + b
                lo, hi = np.searchsorted(skey, kk), np.searchsorted(skey, kk, "right")
                idx.append(order[lo:hi])
        idx = np.concatenate(idx)
        d = xyz[idx] - xyz[i]
        near = (d * d).sum(1) <= R * R
        idx, d = idx[near], d[near]
        c = cls[idx]
        plan = np.minimum(abs(d[:, 0]), abs(d[:, 1]))   # off an axis-aligned wall
        b6 = c == 6
        if k == 1:
            ok = any(((b6 & (d[:, a] > 0.3)).sum() >= 3) and ((b6 & (d[:, a] < -0.3)).sum() >= 3)
                     for a in (0, 1))
        elif k == 2:
            ok = (b6 & (d[:, 2] >= -0.25)).sum() >= 3 and \
                 (b6 & (d[:, 2] < -0.4) & (plan < 0.4)).sum() >= 3
        elif k == 3:
            wall = b6 & (d[:, 2] < 0.3)
            ok = (wall & (abs(d[:, 0]) < 0.3) & (abs(d[:, 1]) > 0.3)).sum() >= 3 and \
                 (wall & (abs(d[:, 1]) < 0.3) & (abs(d[:, 0]) > 0.3)).sum() >= 3
        else:
            ok = (c == 2).sum() >= 3 and (b6 & (d[:, 2] > 0.4) & (plan < 0.4)).sum() >= 3
        seen[k][0] += 1
        seen[k][1] += bool(ok)
    tot = sum(v[0] for v in seen.values())
    both = sum(v[1] for v in seen.values())
    print("%s: truth %d points, both faces observed within %.2f m: %.2f" %
          (sys.argv[1], tot, R, both / max(tot, 1)))
    for k, name in kinds.items():
        n, o = seen[k]
        print("  %-8s %6d points (%.2f of the truth), both faces observed: %.2f" %
              (name, n, n / max(tot, 1), o / max(n, 1)))


if __name__ == "__main__":
    main()
