#!/usr/bin/env python3
"""Compares the line coverage of two test tiers (docs/testing.md).

    tests/coverage_compare.py build/cov/fast.json build/cov/full.json

Reads two gcovr JSON summaries (make coverage TIER=...) and prints, as
Markdown, the total line coverage of each tier, the first's share of the
second's, and a per-folder table; then every file whose coverage by the
first tier is more than 10 points below the second's. Exits 1 when the first
tier's total is under 90 % of the second's or a file is more than 10 points
below, 0 otherwise."""
import collections
import json
import sys


def load(path):
    with open(path) as f:
        doc = json.load(f)
    return {e["filename"]: (e["line_covered"], e["line_total"]) for e in doc["files"]}


def pct(covered, total):
    return 100.0 * covered / total if total else 100.0


def main(fast_path, full_path):
    fast, full = load(fast_path), load(full_path)
    names = sorted(set(fast) | set(full))
    tot = {k: [sum(v[0] for v in d.values()), sum(v[1] for v in d.values())]
           for k, d in (("fast", fast), ("full", full))}
    a, b = pct(*tot["fast"]), pct(*tot["full"])
    print("| tier | lines covered | of | line coverage |\n|---|---:|---:|---:|")
    for k in ("fast", "full"):
        print("| %s | %d | %d | %.1f %% |" % (k, tot[k][0], tot[k][1], pct(*tot[k])))
    share = 100.0 * tot["fast"][0] / tot["full"][0] if tot["full"][0] else 100.0
    print("\nThe fast tier covers %.1f %% of the lines the full tier covers.\n" % share)
    folders = collections.defaultdict(lambda: [0, 0, 0])
    for n in names:
        c1, t = fast.get(n, (0, full.get(n, (0, 0))[1]))
        c2 = full.get(n, (0, t))[0]
        key = n.rsplit("/", 1)[0]
        folders[key][0] += c1
        folders[key][1] += c2
        folders[key][2] += t
    print("| folder | fast | full |\n|---|---:|---:|")
    for key in sorted(folders):
        c1, c2, t = folders[key]
        print("| %s | %.1f %% | %.1f %% |" % (key, pct(c1, t), pct(c2, t)))
    below = []
    for n in names:
        c1, t1 = fast.get(n, (0, 0))
        c2, t2 = full.get(n, (0, 0))
        t = max(t1, t2)
        if pct(c2, t) - pct(c1, t) > 10:
            below.append((n, pct(c1, t), pct(c2, t)))
    print("\nFiles more than 10 points below the full tier: %d" % len(below))
    for n, x, y in below:
        print("- %s: %.1f %% against %.1f %%" % (n, x, y))
    return 1 if share < 90 or below else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2]))
