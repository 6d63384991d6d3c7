#!/usr/bin/python3
"""Writes one LAS 1.0-1.3 file holding k x k copies of a LAS scan, copy (i, j)
shifted by i x (X extent + 100 scale units) and j x (Y extent + 100 scale
units) in the integer coordinates; point count, counts by return and the
box updated, every other header byte, VLR and record byte as the source.
The benchmark cloud of the speed and output-side issues: the NC Raleigh
scan (2,269,213 points) 7 x 7 gives 111,191,437 real LiDAR points (4.2 GB).

usage: make_nc_tiled.py SRC.las OUT.las [K]
"""
import struct
import sys

import numpy as np


def main():
    src, out = sys.argv[1], sys.argv[2]
    k = int(sys.argv[3]) if len(sys.argv) > 3 else 7
    with open(src, "rb") as f:
        data = f.read()
    if data[:4] != b"LASF" or data[25] > 3:
        sys.exit("%s: not a LAS 1.0-1.3 file" % src)
    offset = struct.unpack_from("<I", data, 96)[0]
    rec = struct.unpack_from("<H", data, 105)[0]
    n = struct.unpack_from("<I", data, 107)[0]
    by_return = struct.unpack_from("<5I", data, 111)
    scale = struct.unpack_from("<3d", data, 131)
    off = struct.unpack_from("<3d", data, 155)
    pts = np.frombuffer(data, dtype=np.uint8, count=n * rec, offset=offset).reshape(n, rec)
    xi = pts[:, 0:4].copy().view("<i4").ravel()
    yi = pts[:, 4:8].copy().view("<i4").ravel()
    step_x = int(xi.max()) - int(xi.min()) + 100
    step_y = int(yi.max()) - int(yi.min()) + 100
    head = bytearray(data[:offset])
    struct.pack_into("<I", head, 107, n * k * k)
    struct.pack_into("<5I", head, 111, *[c * k * k for c in by_return])
    lo_x = (int(xi.min())) * scale[0] + off[0]
    hi_x = (int(xi.max()) + (k - 1) * step_x) * scale[0] + off[0]
    lo_y = (int(yi.min())) * scale[1] + off[1]
    hi_y = (int(yi.max()) + (k - 1) * step_y) * scale[1] + off[1]
    struct.pack_into("<4d", head, 179, hi_x, lo_x, hi_y, lo_y)
    if (int(xi.max()) + (k - 1) * step_x) >= 2**31 or (int(yi.max()) + (k - 1) * step_y) >= 2**31:
        sys.exit("the shifted coordinates do not fit 32-bit integers")
    with open(out, "wb") as f:
        f.write(head)
        copy = pts.copy()
        for i in range(k):
            for j in range(k):
                copy[:, 0:4] = (xi + i * step_x).astype("<i4").view(np.uint8).reshape(n, 4)
                copy[:, 4:8] = (yi + j * step_y).astype("<i4").view(np.uint8).reshape(n, 4)
                f.write(copy.tobytes())
        f.write(data[offset + n * rec:])  # anything after the points (none in LAS 1.2)
    print("wrote %d points (%d x %d copies of %d) to %s" % (n * k * k, k, k, n, out))


if __name__ == "__main__":
    main()
