#!/usr/bin/python3
"""Precision and recall of the sharp-feature labels on the oblique survey
(docs/algorithm.md section 5), per seed, for one wpd binary:

  detector  `wpd edges --cap R0` on every input point against edge_truth
            (R0: the radius estimate of a run to 1 %), as tests/e2e/test_edges.py
            computes it: precision = labelled points that are truth /
            labelled, recall = truth points labelled / truth points;
  resample  the labels `wpd resample -n 1% --sharp --edge-label` writes (the
            path users run, smoothing on), each output sample's label
            against the edge_truth of the input point it came from (the
            record carries it), same definitions over the samples.

Usage: sharp_labels.py WPD [SEEDS] [N]   (SEEDS like 1-10 or 1,3; N 300000)
Prints one line per seed and, for each, the number of seeds with both >= 0.8. The
clouds are made once in bench/out/labels and reused.
"""
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 2)[0] + "/tests/e2e")
from formats import read_las  # noqa: E402

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "out", "labels")


def field(h, name):
    """The uint8 extra field `name` of a LAS file (read_las), by its Extra
    Bytes descriptor (192 bytes each, name at 4..36)."""
    vlr = [p for u, rid, p in h["vlrs"] if u == b"LASF_Spec" and rid == 4][0]
    names = [vlr[k + 4:k + 36].split(b"\0")[0].decode() for k in range(0, len(vlr), 192)]
    rl = h["record_length"]
    off = rl - len(names) + names.index(name)       # one byte each, at the end
    return np.frombuffer(h["points"], np.uint8).reshape(-1, rl)[:, off].copy()


def pr(truth, edge):
    tp = int(((truth > 0) & (edge == 1)).sum())
    return tp / max(int(edge.sum()), 1), tp / max(int((truth > 0).sum()), 1)


def run(*args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True,
                          text=True).stdout


def seeds_of(spec):
    if "-" in spec:
        a, b = spec.split("-")
        return range(int(a), int(b) + 1)
    return [int(s) for s in spec.split(",")]


def main():
    wpd = os.path.abspath(sys.argv[1])
    seeds = seeds_of(sys.argv[2] if len(sys.argv) > 2 else "1-10")
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 300000
    os.makedirs(OUT, exist_ok=True)
    ok = rok = 0
    print("seed  r0      edges: labelled precision recall   resample: labelled precision recall")
    for s in seeds:
        city = os.path.join(OUT, f"oblique_{n}_{s}.las")
        if not os.path.exists(city):
            run(wpd, "synth", "-n", n, "--seed", s, "-o", city, "--edge-truth", "--oblique")
        tmp = os.path.join(OUT, f"r_{os.getpid()}.las")
        said = run(wpd, "resample", city, "-o", tmp, "-n", "1%", "-v", "--no-smooth", "--force")
        r0 = re.search(r"estimate ([0-9.]+)", said).group(1)
        run(wpd, "edges", city, "--truth", "edge_truth", "--cap", r0, "-o", tmp, "--force")
        h = read_las(tmp)
        ep, er = pr(field(h, "edge_truth"), field(h, "edge"))
        elab = int(field(h, "edge").sum())
        run(wpd, "resample", city, "-o", tmp, "-n", "1%", "--sharp", "--edge-label", "--force",
            "-q")
        h = read_las(tmp)
        rp, rr = pr(field(h, "edge_truth"), field(h, "edge"))
        rlab = int(field(h, "edge").sum())
        os.unlink(tmp)
        ok += ep >= 0.8 and er >= 0.8
        rok += rp >= 0.8 and rr >= 0.8
        print(f"{s:4d}  {float(r0):.3f}  {elab:8d} {ep:9.3f} {er:6.3f}   {rlab:17d} {rp:9.3f} "
              f"{rr:6.3f}", flush=True)
    print(f"edges: precision and recall both >= 0.8 on {ok} of {len(seeds)} seeds")
    print(f"resample: precision and recall both >= 0.8 on {rok} of {len(seeds)} seeds")


if __name__ == "__main__":
    main()
