#!/usr/bin/env python3
"""How many input points a pruned cost query of the exact count could skip.

A model, not a benchmark: it measures the potential of an idea before it is
built (docs/engine.md, "What reaching the issue's 11 s would take").

The exact count's cost of a sample s is the largest distance from an input
point whose nearest sample is s to that point's second-nearest sample
(method/eliminate.h). Costs are maxima, so a cell of input points can be
skipped without changing any cost when every sample that can be the nearest
of one of its points already has a cost at least the cell's bound on the
second-nearest distance. Two cases are counted, per cell size:
  - "cold": each sample's cost starts at its distance to its nearest other
    sample (its own input point's contribution, known before any input
    point is read);
  - "final": the costs once every point is in (a perfectly warmed order).
Cells are cubes of a fraction of r (the median nearest-sample distance);
the bound uses the cell's points' centroid and their largest distance from
it.

usage: /usr/bin/python3 bench/cost_prune_model.py INPUT SAMPLES
  SAMPLES: a Poisson sample of INPUT as the exact count sees it, e.g. the
  first pass's count written without smoothing:
  ./wpd resample NC.las -o s.las -n 10462 --no-smooth
Needs numpy and scipy (Debian: python3-numpy python3-scipy).
"""
import os
import sys

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "shared", "tools"))
import pcio  # noqa: E402  (../shared/tools: the independent reader)


def load(path):
    return np.asarray(pcio.read_points(path), dtype=float)[:, :3]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    points, samples = load(sys.argv[1]), load(sys.argv[2])
    tree = cKDTree(samples)
    d, i = tree.query(points, k=2)
    cost = np.zeros(len(samples))
    np.maximum.at(cost, i[:, 0], d[:, 1])
    nearest = tree.query(samples, k=2)[0][:, 1]
    r = np.median(nearest)
    for frac in (0.25, 0.5, 1.0):
        cell = np.floor((points - points.min(0)) / (frac * r)).astype(np.int64)
        _, inv = np.unique(cell, axis=0, return_inverse=True)
        inv = inv.ravel()
        count = np.bincount(inv)
        centre = np.zeros((len(count), 3))
        np.add.at(centre, inv, points)
        centre /= count[:, None]
        spread = np.zeros(len(count))
        np.maximum.at(spread, inv, np.linalg.norm(points - centre[inv], axis=1))
        dc, ic = tree.query(centre, k=8)
        second = dc[:, 1] + spread  # no point of the cell has its second nearest farther
        complete = dc[:, 7] > dc[:, 0] + 2 * spread  # every possible nearest among the 8
        shares = []
        for name, start in (("cold", nearest), ("final", cost)):
            skip = complete.copy()
            for j in range(8):
                may_be_nearest = dc[:, j] <= dc[:, 0] + 2 * spread
                skip &= ~may_be_nearest | (start[ic[:, j]] >= second)
            shares.append(f"{name} {count[skip].sum() / len(points):.3f}")
        print(f"cells of {frac:.2f} r: {len(count)} cells, {count.mean():.1f} points a cell; "
              f"share of points skipped: {', '.join(shares)}")


if __name__ == "__main__":
    main()
