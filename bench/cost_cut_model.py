#!/usr/bin/env python3
"""How many samples, and input points, an exact count that computed costs
only for the samples that can be cut would still need.

A model, not a benchmark: it measures an idea before it is built
(docs/engine.md, Speed). A sweep of the exact count takes the samples up to
the cost of rank K = q + min(q, m/20) (q deletions to make, m samples), and
a sample's cost is at least its distance to its nearest other sample (its
own input point's contribution). So only the samples whose lower bound is
at most the cut T can be candidates, and only the input points whose
nearest sample is one of them would need a query. Prints, with T known (the
best case), the share of samples and of input points that remain; and for
cuts guessed from the lower bounds (the mult x K-th smallest bound), whether
they would settle the sweep in one reading.

usage: /usr/bin/python3 bench/cost_cut_model.py INPUT SAMPLES N
  SAMPLES: the first pass's samples, e.g. one Poisson pass at the run's
  radius: wpd resample INPUT -o s.las --append --spacing R --no-smooth
  (R: the radius `wpd resample INPUT -n N -v` prints); N the target.
Needs numpy and scipy (Debian: python3-numpy python3-scipy).
"""
import sys

import numpy as np
from scipy.spatial import cKDTree

from cost_prune_model import load  # the same reader (../shared/tools/pcio.py)


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    pts, smp, n = load(sys.argv[1]), load(sys.argv[2]), int(sys.argv[3])
    m = len(smp)
    q = m - n
    k = q + min(q, m // 20)
    tree = cKDTree(smp)
    d, i = tree.query(pts, k=2)
    cost = np.zeros(m)
    np.maximum.at(cost, i[:, 0], d[:, 1])
    bound = tree.query(smp, k=2)[0][:, 1]
    cut = np.sort(cost)[k - 1]
    print(f"samples {m}, target {n}, cut rank {k}, cut {cut / np.median(bound):.3f} x the median "
          f"nearest-sample distance; bound <= cost everywhere: {(bound <= cost + 1e-9).all()}")
    for mult in (0, 1.5, 2, 3, 4):
        guess = cut if mult == 0 else np.sort(bound)[min(m - 1, int(mult * k))]
        need = bound <= guess
        settles = need.sum() >= k and (np.sort(cost[need])[:k] <= guess).sum() >= k
        print(f"{'the cut known' if mult == 0 else f'guess {mult} x rank':>16}: samples "
              f"{need.mean():.3f}, input points {need[i[:, 0]].mean():.3f}, settles {settles}")


if __name__ == "__main__":
    main()
