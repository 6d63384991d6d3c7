#!/usr/bin/env python3
"""Makes the committed LAZ fuzz seeds (tests/fuzz/seeds-laz/): small LAZ
files that LASzip itself wrote, for what the shared data's LAZ files do not
hold - scanner channels that change within a chunk (the layered items'
contexts) with colour, NIR and extra bytes, returns up to 15, high
classes, NaN GPS times, chunks of 1, 2 and 7 points, LASzip's variable
chunks, an empty file, and point formats 0-3 - plus one file as an older
wpd wrote it (generating software "wpd" and wpd's LASzip VLR), which makes
the reader decode its first chunk at open (docs/formats.md, "Scanner
channels").

  make_laz_seeds.py LASZIP_DIR WPD OUT_DIR

LASZIP_DIR holds laszip_enc (`make laszip`: build/laszip); WPD is the wpd
binary. The points are synthetic (a seeded generator, no shared data), so
the seeds may be committed; the same programs give the same bytes. The
fuzz runs (make_seeds.py) only copy them: they need no LASzip.
"""
import os
import random
import struct
import subprocess
import sys
import tempfile

CORE = {0: 20, 1: 28, 2: 26, 3: 34, 6: 30, 7: 36, 8: 38}


def records(pdrf, n, extra, seed, channels="runs", nan_gps=False, high=False):
    """n synthetic records of point format pdrf with extra bytes: a walk in
    X, Y and Z, intensities, return numbers and counts (up to 15 with
    high), classes (above 31 with high) and flags, scan angles, user data,
    sources, GPS times (some NaN with nan_gps), colour changing one channel
    at a time with grey runs, NIR, and scanner channels (formats 6-8) in
    runs, at random, or none ("one": all channel 1)."""
    rnd = random.Random(seed)
    out = bytearray()
    x = y = z = 0
    rgb = [1000, 20000, 300, 40000]
    ch, t = 0, 1e5
    for i in range(n):
        x += rnd.randint(-300, 300)
        y += rnd.randint(-300, 300)
        z += rnd.randint(-50, 50) if rnd.random() < 0.7 else 0
        if channels == "runs" and rnd.random() < 0.05 or channels == "random":
            ch = rnd.randint(0, 3)
        elif channels == "one":
            ch = 1
        t += 0.0 if rnd.random() < 0.3 else rnd.choice((1e-5, 2e-5, 3.5))
        gps = float("nan") if nan_gps and rnd.random() < 0.1 else t
        nret = rnd.randint(1, 15 if high else 5)
        ret = rnd.randint(1, nret)
        cls = rnd.choice((2, 5, 6, 200 if high else 9, 64 if high else 2))
        if rnd.random() < 0.5:
            k = rnd.randint(0, 3)
            rgb[k] = (rgb[k] + rnd.randint(-600, 600)) & 0xFFFF
        elif rnd.random() < 0.2:
            rgb[1] = rgb[2] = rgb[0]
        if pdrf >= 6:
            flags = rnd.randint(0, 15) if high else 0
            flags |= ch << 4 | rnd.randint(0, 1) << 6 | (rnd.random() < 0.05) << 7
            rec = struct.pack("<iiiHBBBBhHd", x, y, z, rnd.randint(0, 65535),
                              ret | nret << 4, flags, cls, rnd.randint(0, 255),
                              rnd.randint(-15000, 15000), rnd.randint(1, 3), gps)
            if pdrf >= 7:
                rec += struct.pack("<HHH", *rgb[:3])
            if pdrf == 8:
                rec += struct.pack("<H", rgb[3])
        else:
            bits = min(ret, 7) | min(nret, 7) << 3 | rnd.randint(0, 3) << 6
            rec = struct.pack("<iiiHBBbBH", x, y, z, rnd.randint(0, 65535), bits, cls & 31,
                              rnd.randint(-90, 90), rnd.randint(0, 255), rnd.randint(1, 3))
            if pdrf in (1, 3):
                rec += struct.pack("<d", gps)
            if pdrf in (2, 3):
                rec += struct.pack("<HHH", *rgb[:3])
        rec += bytes(rnd.randint(0, 255) if j % 2 else i // 7 & 255 for j in range(extra))
        assert len(rec) == CORE[pdrf] + extra
        out += rec
    return bytes(out)


def las(pdrf, n, extra, recs):
    """A LAS file (1.2 for formats 0-3, 1.4 for 6-8) holding recs, its
    bounds and points by return those of the records."""
    v14 = pdrf >= 6
    rl = CORE[pdrf] + extra
    xyz = [struct.unpack_from("<iii", recs, i * rl) for i in range(n)]
    by_return = [0] * 15
    for i in range(n):
        b = recs[i * rl + 14]
        r = b & 15 if v14 else b & 7
        if 1 <= r <= (15 if v14 else 5):
            by_return[r - 1] += 1
    size = 375 if v14 else 227
    h = bytearray(size)
    h[0:4] = b"LASF"
    h[24], h[25] = 1, 4 if v14 else 2
    h[26:26 + 9] = b"fuzz seed"
    h[58:58 + 24] = b"make_laz_seeds.py LASzip"
    struct.pack_into("<HHHIIBHI", h, 90, 1, 2024, size, size, 0, pdrf, rl, 0 if v14 else n)
    so = (0.01, 0.01, 0.01, 1000.0, 2000.0, 0.0)
    struct.pack_into("<6d", h, 131, *so)
    for k in range(3):
        v = [p[k] * so[k] + so[3 + k] for p in xyz] or [0.0]
        struct.pack_into("<dd", h, 179 + 16 * k, max(v), min(v))
    if v14:
        struct.pack_into("<Q15Q", h, 247, n, *by_return)
    else:
        struct.pack_into("<5I", h, 111, *by_return[:5])
    return bytes(h) + recs


# name: (point format, points, extra bytes, chunk points (0: variable),
# generator options)
SEEDS = {
    "laszip-6-channels-runs": (6, 300, 0, 50000, {}),
    "laszip-6-returns15-class-high": (6, 200, 2, 50000, {"channels": "random", "high": True}),
    "laszip-6-chunks-of-2": (6, 60, 2, 2, {"channels": "random"}),
    "laszip-7-channels-random-colour": (7, 300, 0, 50000, {"channels": "random"}),
    "laszip-7-chunks-of-1": (7, 40, 1, 1, {"channels": "random"}),
    "laszip-7-variable-chunks-nan-gps": (7, 250, 0, 0, {"nan_gps": True}),
    "laszip-8-channels-nir-extra": (8, 300, 3, 50000, {"channels": "random"}),
    "laszip-8-chunks-of-7": (8, 200, 3, 7, {"channels": "runs"}),
    "laszip-8-empty": (8, 0, 3, 50000, {}),
    "laszip-0-extra": (0, 300, 2, 50000, {}),
    "laszip-1-chunks-of-7": (1, 150, 0, 7, {"nan_gps": True}),
    "laszip-2-colour": (2, 300, 0, 50000, {}),
    "laszip-3-extra": (3, 300, 3, 50000, {"high": True}),
}


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: make_laz_seeds.py LASZIP_DIR WPD OUT_DIR")
    enc, wpd, out = os.path.join(sys.argv[1], "laszip_enc"), sys.argv[2], sys.argv[3]
    os.makedirs(out, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="laz-seeds-")
    src = os.path.join(tmp, "in.las")
    for i, (name, (pdrf, n, extra, chunk, opt)) in enumerate(sorted(SEEDS.items())):
        with open(src, "wb") as f:
            f.write(las(pdrf, n, extra, records(pdrf, n, extra, 1000 + i, **opt)))
        dst = os.path.join(out, name + ".laz")
        subprocess.run([enc, src, dst, "1", str(chunk)], check=True, capture_output=True)
    # As an older wpd wrote it: wpd's LAZ with "wpd" alone as generating
    # software, its first chunk's points changing channel.
    with open(src, "wb") as f:
        f.write(las(7, 300, 2, records(7, 300, 2, 7, channels="random")))
    dst = os.path.join(out, "old-wpd-7-channels.laz")
    subprocess.run([wpd, "convert", src, dst, "--force"], check=True, capture_output=True)
    with open(dst, "r+b") as f:
        f.seek(58)
        f.write(b"wpd".ljust(32, b"\0"))
    os.remove(src)
    os.rmdir(tmp)
    sizes = {n: os.path.getsize(os.path.join(out, n)) for n in sorted(os.listdir(out))}
    print("%d seeds in %s, %d to %d bytes" % (len(sizes), out, min(sizes.values()),
                                              max(sizes.values())))


if __name__ == "__main__":
    main()
