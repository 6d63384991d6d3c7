#!/usr/bin/env python3
"""Seeds for fuzz_collection (Makefile: make fuzz-seeds): states as wpd
writes them - a --per-input folder after two nights with a pending rename,
an --append output, a first night with class options and empty boxes.

    make_collection_seeds.py OUT_DIR"""
import os
import sys

HEAD = """{
  "format": "wpd-collection",
  "version": 1,
  "wpd": "0.2.0",
  "radius": %s,
  "density_factor": %s,
  "spacing": %s,
  "options": {"lambda": 0.68000000000000005, "voxel_frac": 0.050000000000000003, \
"radius_estimate": "%s", "k": 13, "iterations": 5, "even_steps": 4, "smooth": true, \
"sharp": %s, "seed": %s, "drop_class": "%s", "keep_class": "%s", "class_field": "%s"},
  "nights": %d,
"""


def entry(name, out, first, points, night, box="500000, 4500000, 108.38, 500091.28, 4500091.28, 212.84"):
    return ('    {"name": "%s", "size": 3141385, "mtime_ns": 1795846567775933198, "bounds": [%s], '
            '"output": "%s", "first": %d, "points": %d, "output_bounds": [%s], "night": %d}'
            % (name, box, out, first, points, box, night))


def state(head, outputs, inputs, pending):
    s = head + '  "outputs": [' + (",\n".join(
        '\n    {"name": "%s", "size": %d}' % o for o in outputs) + "\n  ]" if outputs else "]")
    s += ',\n  "inputs": [' + ("\n" + ",\n".join(inputs) + "\n  ]" if inputs else "]")
    s += ',\n  "pending": [' + (",\n".join(
        '\n    {"from": "%s", "to": "%s"}' % p for p in pending) + "\n  ]" if pending else "]")
    return s + "\n}\n"


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    seeds = {
        "per_input": state(HEAD % ("0.76914416441779376", "0.92748989831712625", "false",
                                   "multiscale", "false", "0", "", "", "", 2),
                           [("a.las", 320303), ("b\\u00e9.las", 390547)],
                           [entry("a.las", "a.las", 0, 9411, 1),
                            entry("b\\u00e9.las", "b\\u00e9.las", 0, 11477, 2)],
                           [(".b\\u00e9.las.wpd-tmp-vm-123-abcdef", "b\\u00e9.las")]),
        "append": state(HEAD % ("1.5", "1", "true", "paper", "true", "18446744073709551615",
                                "7,18", "", "cls", 3),
                        [("all.las", 708345)],
                        [entry("t1.las", "all.las", 0, 9238, 1),
                         entry("t2.las", "all.las", 9238, 11586, 3)], []),
        "empty": state(HEAD % ("2", "0.5", "false", "multiscale", "false", "1", "", "2,6,9-12",
                               "", 1),
                       [("e.ply", 10)],
                       [entry("e.ply", "e.ply", 0, 0, 1, "null, null, null, null, null, null")],
                       []),
    }
    for name, text in seeds.items():
        with open(os.path.join(out, name), "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
