"""Writes an ascii PLY like a scanner or CloudCompare export: float x y z
with millimetre decimals, uchar red green blue, float normals with 6
decimals. Usage: make_ascii_ply.py N OUT"""
import sys

import numpy as np

n, out = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(1)
xyz = rng.uniform([0, 0, 0], [200, 200, 40], (n, 3))
rgb = rng.integers(0, 256, (n, 3))
nrm = rng.normal(size=(n, 3))
nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
with open(out, "w") as f:
    f.write("ply\nformat ascii 1.0\ncomment bench file\nelement vertex %d\n" % n)
    for p in ("float x", "float y", "float z", "uchar red", "uchar green", "uchar blue",
              "float nx", "float ny", "float nz"):
        f.write("property %s\n" % p)
    f.write("end_header\n")
    step = 1_000_000
    for i in range(0, n, step):
        block = np.hstack([xyz[i:i + step], rgb[i:i + step], nrm[i:i + step]])
        np.savetxt(f, block, fmt="%.3f %.3f %.3f %d %d %d %.6f %.6f %.6f")
