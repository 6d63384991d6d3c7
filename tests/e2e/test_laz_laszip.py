"""LAZ conformance with LASzip, the reference implementation: for the LAS
files of point format 0-3 and 6-8 in ../shared/data and for generated
variants of them, in both directions:

- LASzip's LAZ (laszip_enc) read by wpd (`wpd convert X.laz X.las`) holds
  the records of the original, byte for byte;
- wpd's LAZ (`wpd convert X.las X.laz`) read by LASzip (laszip_enc back
  to LAS) holds the records of the original;
- wpd's LAZ is LASzip's in the point data and the chunk table, byte for
  byte (headers may differ: software strings, VLR descriptions), and the
  LASzip VLRs agree but for the version numbers.

The variants exercise what single-channel real data does not: scanner
channels 0-3 at random, in runs and changing inside a chunk (the layered
items' contexts), return numbers and counts up to 15, classifications
above 31 and every flag, colour and NIR changing one channel at a time,
extra bytes, constant fields (empty layers), NaN GPS times, chunks of 1, 2
and 50,000 points and chunks that start on channels 1-3 (laszip_enc's
chunk argument; WPD_TEST_LAZ_CHUNK for wpd), LASzip's variable chunks
(read by wpd) and empty files.

Fast tier (make test): the variants on a few thousand points (a few
hundred for chunks of 1 and 2 points, 1,000-point chunks for channels
starting a chunk) and the real files of at most 10,000 points. Full tier
(make test-full, marked slow): every real file (up to 2,000 points also
in chunks of 1 and 2), the variants on 60,000 points with 7,777-point
chunks too, and the scans of ../shared/data/scans.

The LASzip programs are those of ../shared/tools/laszip (`make laszip`
builds them into build/laszip), found in $WPD_LASZIP_DIR or build/laszip;
without them the tests SKIP. `python3 test_laz_laszip.py [scans]` prints
the full tier's table."""
import hashlib
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

from harness import DATA, REPO, WPD, Skip, data, manifest

LASZIP_DIR = os.environ.get("WPD_LASZIP_DIR") or os.path.join(REPO, "build", "laszip")
FORMATS = (0, 1, 2, 3, 6, 7, 8)
CORE = {0: 20, 1: 28, 2: 26, 3: 34, 6: 30, 7: 36, 8: 38}
SHOW = os.environ.get("WPD_LASZIP_SHOW")  # print one line per case


def laszip(name):
    path = os.path.join(LASZIP_DIR, name)
    if not os.access(path, os.X_OK):
        raise Skip("SKIP: no %s (build it with `make laszip`, or set WPD_LASZIP_DIR)" % path)
    return path


def run(*cmd, env=None):
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env)


# ---- LAS files ----

def las_facts(b):
    """(point format, record length, point count, offset to points) of LAS
    or LAZ bytes b."""
    count = struct.unpack_from("<I", b, 107)[0]
    if (b[24], b[25]) >= (1, 4) and len(b) >= 255:
        count = struct.unpack_from("<Q", b, 247)[0] or count
    return (b[104] & 0x3F, struct.unpack_from("<H", b, 105)[0], count,
            struct.unpack_from("<I", b, 96)[0])


def head_facts(path):
    """las_facts of the LAS or LAZ file at path."""
    with open(path, "rb") as f:
        return las_facts(f.read(375))


def las_records(path):
    """(point format, scale and offset (6 doubles), records as an n x length
    uint8 array) of a LAS file."""
    with open(path, "rb") as f:
        b = f.read()
    pdrf, length, n, off = las_facts(b)
    recs = np.frombuffer(b, np.uint8, n * length, off).reshape(n, length).copy()
    return pdrf, struct.unpack_from("<6d", b, 131), recs


def write_las(path, pdrf, recs, so=(0.01, 0.01, 0.01, 0.0, 0.0, 0.0)):
    """A LAS file of point format pdrf holding recs (n x length uint8): LAS
    1.2 for formats 0-3, 1.4 for 6-8, no VLRs (extra bytes undescribed)."""
    n, length = recs.shape
    v14 = pdrf >= 6
    size = 375 if v14 else 227
    h = bytearray(size)
    h[0:4] = b"LASF"
    h[24], h[25] = 1, 4 if v14 else 2
    h[26:58] = b"wpd test_laz_laszip".ljust(32, b"\0")
    struct.pack_into("<HHHII", h, 90, 1, 2024, size, size, 0)
    h[104] = pdrf
    struct.pack_into("<HI", h, 105, length, n if not v14 else 0)
    struct.pack_into("<6d", h, 131, *so)
    if n:
        xyz = recs[:, :12].copy().view("<i4").reshape(n, 3)
        lo, hi = xyz.min(0), xyz.max(0)
        for k in range(3):
            struct.pack_into("<dd", h, 179 + 16 * k, hi[k] * so[k] + so[3 + k],
                             lo[k] * so[k] + so[3 + k])
    if v14:
        struct.pack_into("<Q", h, 247, n)
    with open(path, "wb") as f:
        f.write(bytes(h))
        f.write(recs.tobytes())


# Field offsets of the record formats (LAS 1.4 specification, tables 7-16).
P10 = {"x": 0, "y": 4, "z": 8, "intensity": 12, "bits": 14, "class": 15, "angle": 16,
       "user": 17, "source": 18}
P14 = {"x": 0, "y": 4, "z": 8, "intensity": 12, "returns": 14, "flags": 15, "class": 16,
       "user": 17, "angle": 18, "source": 20, "gps": 22}


def gps_at(pdrf):
    return {1: 20, 3: 20}.get(pdrf, 22 if pdrf >= 6 else None)


def rgb_at(pdrf):
    return {2: 20, 3: 28, 7: 30, 8: 30}.get(pdrf)


def put(recs, at, values, dtype):
    """Writes values (one per record) as dtype at byte at of every record."""
    v = np.asarray(values).astype(dtype)
    recs[:, at:at + v.dtype.itemsize] = v.reshape(-1, 1).view(np.uint8)


def get(recs, at, dtype):
    size = np.dtype(dtype).itemsize
    return recs[:, at:at + size].copy().view(dtype).reshape(-1)


def runs(rng, n, values, mean):
    """n values drawn from values, in runs of about mean points."""
    out = np.empty(n, np.int64)
    i = 0
    while i < n:
        k = int(rng.geometric(1.0 / mean))
        out[i:i + k] = rng.choice(values)
        i += k
    return out


def convert(recs, src, dst):
    """Records of point format src laid out as dst (fields both have kept,
    the others made up: NIR from the colour, GPS times from the index)."""
    n = len(recs)
    out = np.zeros((n, CORE[dst]), np.uint8)
    out[:, :12] = recs[:, :12]
    put(out, 12, get(recs, 12, "<u2"), "<u2")
    if src >= 6:
        ret, nret = recs[:, 14] & 15, recs[:, 14] >> 4
        cls, user, angle, source = (recs[:, 16], recs[:, 17], get(recs, 18, "<i2"),
                                    get(recs, 20, "<u2"))
        flags = recs[:, 15]
    else:
        ret, nret = recs[:, 14] & 7, (recs[:, 14] >> 3) & 7
        cls, user, angle, source = (recs[:, 15], recs[:, 17], recs[:, 16].view(np.int8),
                                    get(recs, 18, "<u2"))
        flags = (recs[:, 14] >> 6) << 6
    gps = get(recs, gps_at(src), "<f8") if gps_at(src) else np.arange(n) * 1e-4 + 1e5
    rgb = (recs[:, rgb_at(src):rgb_at(src) + 6].copy() if rgb_at(src)
           else np.tile(np.array([1, 2, 3, 4, 5, 6], np.uint8), (n, 1)))
    if dst >= 6:
        out[:, 14] = np.minimum(ret, 15) | np.minimum(nret, 15) << 4
        out[:, 15] = flags
        out[:, 16], out[:, 17] = cls, user
        put(out, 18, angle.astype(np.int32) * (1 if src >= 6 else 167), "<i2")
        put(out, 20, source, "<u2")
    else:
        out[:, 14] = np.minimum(ret, 7) | np.minimum(nret, 7) << 3 | (flags >> 6) << 6
        out[:, 15], out[:, 17] = cls, user
        out[:, 16] = np.clip(angle.astype(np.int32) // (1 if src < 6 else 167), -128,
                             127).astype(np.int8).view(np.uint8)
        put(out, 18, source, "<u2")
    if gps_at(dst):
        put(out, gps_at(dst), gps, "<f8")
    if rgb_at(dst):
        out[:, rgb_at(dst):rgb_at(dst) + 6] = rgb
    if dst == 8:
        put(out, 36, (get(out, 30, "<u2").astype(np.int64) + get(out, 32, "<u2")) // 2, "<u2")
    return out


def set_channels(recs, ch):
    recs[:, 15] = (recs[:, 15] & 0xCF) | (np.asarray(ch, np.uint8) & 3) << 4


def with_extra(recs, rng, k=5):
    """recs with k extra bytes: constant, random, a counter, a slow step,
    random in runs."""
    n = len(recs)
    extra = np.zeros((n, k), np.uint8)
    cols = [np.full(n, 7), rng.integers(0, 256, n), np.arange(n) & 255,
            (np.arange(n) >> 10) & 255, runs(rng, n, np.arange(256), 30)]
    for j in range(k):
        extra[:, j] = cols[j % len(cols)]
    return np.concatenate([recs, extra], axis=1)


def colour_steps(recs, pdrf, rng):
    """Colour (and NIR) changing one channel at a time, with grey runs and
    constant runs between."""
    n = len(recs)
    at = rgb_at(pdrf)
    k = 4 if pdrf == 8 else 3
    c = np.zeros((n, 4), np.int64)
    cur = np.array([1000, 20000, 300, 40000])
    mode = runs(rng, n, [0, 1, 2], 200)
    for i in range(n):
        if mode[i] == 0:
            j = i % k
            cur[j] = (cur[j] + int(rng.integers(-600, 600))) & 0xFFFF
        elif mode[i] == 1:
            cur[:3] = cur[0]
        c[i] = cur
    for j in range(3):
        put(recs, at + 2 * j, c[:, j], "<u2")
    if pdrf == 8:
        put(recs, 36, c[:, 3], "<u2")


# The generated variants: name -> records made from base (records of the
# point format, the first points of a real file), rng and span (the chunk
# size at which chunks should start on channels 1-3 and switch inside).

def _channels_random(b, pdrf, rng, span):
    set_channels(b, rng.integers(0, 4, len(b)))
    return b


def _channels_runs(b, pdrf, rng, span):
    set_channels(b, runs(rng, len(b), [0, 1, 2, 3], 150))
    return b


def _channels_in_chunks(b, pdrf, rng, span):
    """Runs of 0.46 span points from the channel after the one before, a
    few random points of channel 3 between: chunks of span points start on
    channels 1-3 and switch inside."""
    n = len(b)
    ch = (np.arange(n) + span * 34 // 100) // (span * 46 // 100) % 4
    ch[rng.integers(0, n, max(1, n // 1500))] = 3
    set_channels(b, ch)
    return b


def _returns_15(b, pdrf, rng, span):
    n = len(b)
    set_channels(b, rng.integers(0, 2, n))
    b[:, 14] = runs(rng, n, np.arange(16), 3) | runs(rng, n, np.arange(16), 5) << 4
    return b


def _class_flags_high(b, pdrf, rng, span):
    n = len(b)
    set_channels(b, rng.integers(0, 4, n))
    b[:, 16] = runs(rng, n, np.arange(256), 4)
    b[:, 15] = (b[:, 15] & 0x30) | (runs(rng, n, np.arange(256), 6) & 0xCF)
    b[:, 17] = runs(rng, n, np.arange(256), 8)
    put(b, 18, runs(rng, n, np.arange(-30000, 30000, 7), 5), "<i2")
    put(b, 20, runs(rng, n, np.arange(65536), 40), "<u2")
    return b


def _colour_steps14(b, pdrf, rng, span):
    set_channels(b, runs(rng, len(b), [0, 1, 2, 3], 20))
    colour_steps(b, pdrf, rng)
    return b


def _extra_bytes14(b, pdrf, rng, span):
    r = with_extra(b, rng)
    set_channels(r, rng.integers(0, 4, len(r)))
    return r


def _gps_nan_jumps14(b, pdrf, rng, span):
    """NaN GPS times (always a change for LASzip), repeats, jumps."""
    r = b[:5000]
    set_channels(r, runs(rng, len(r), [0, 1, 2, 3], 10))
    g = get(r, 22, "<f8")
    g[rng.integers(0, len(r), len(r) // 16)] = np.nan
    g[rng.integers(0, len(r), len(r) // 50)] += 1e9
    put(r, 22, g, "<f8")
    return r


def _constant(b, pdrf, rng, span):
    """Everything constant but X and Y: empty layers (formats 6-8)."""
    r = b[:3000]
    r[:, 8:] = r[0, 8:]
    if pdrf >= 7:
        put(r, 30, np.full(len(r), 513), "<u2")
    return r


def _small_mixed14(b, pdrf, rng, span):
    """For chunks of 1 and 2 points: extra bytes, every channel, any
    return byte."""
    r = with_extra(b, rng, 3)
    set_channels(r, rng.integers(0, 4, len(r)))
    r[:, 14] = rng.integers(0, 256, len(r))
    return r


def _empty(b, pdrf, rng, span):
    return b[:0]


def _returns_flags(b, pdrf, rng, span):
    b[:, 14] = runs(rng, len(b), np.arange(256), 3)
    return b


def _class_angle_user_source(b, pdrf, rng, span):
    n = len(b)
    b[:, 15] = runs(rng, n, np.arange(256), 4)
    b[:, 16] = runs(rng, n, np.arange(256), 6)
    b[:, 17] = runs(rng, n, np.arange(256), 8)
    put(b, 18, runs(rng, n, np.arange(65536), 40), "<u2")
    return b


def _gps_nan_jumps10(b, pdrf, rng, span):
    r = b[:20000]
    g = get(r, 20, "<f8")
    for v in (np.nan, None, -0.0):
        at = rng.integers(0, len(r), max(1, len(r) // 66))
        g[at] = v if v is not None else g[at] + 1e9
    put(r, 20, g, "<f8")
    return r


def _colour_steps10(b, pdrf, rng, span):
    colour_steps(b, pdrf, rng)
    return b


def _small_mixed10(b, pdrf, rng, span):
    r = with_extra(b, rng, 3)
    r[:, 14] = rng.integers(0, 256, len(r))
    return r


VARIANTS = {
    # formats 6-8, from pdal_autzen_trim_7
    14: {"channels_random": _channels_random, "channels_runs": _channels_runs,
         "channels_in_chunks": _channels_in_chunks, "returns_15": _returns_15,
         "class_flags_high": _class_flags_high, "colour_steps": _colour_steps14,
         "extra_bytes": _extra_bytes14, "gps_nan_jumps": _gps_nan_jumps14,
         "constant": _constant, "small_mixed": _small_mixed14, "empty": _empty},
    # formats 0-3, from pdal_autzen_trim
    10: {"autzen": lambda b, pdrf, rng, span: b, "returns_flags": _returns_flags,
         "class_angle_user_source": _class_angle_user_source,
         "gps_nan_jumps": _gps_nan_jumps10, "colour_steps": _colour_steps10,
         "extra_bytes": lambda b, pdrf, rng, span: with_extra(b, rng),
         "constant": _constant, "small_mixed": _small_mixed10, "empty": _empty},
}


def variant_applies(name, pdrf):
    """Whether variant name makes sense for point format pdrf (a GPS
    variant needs GPS times, a colour one colour)."""
    if name == "colour_steps":
        return rgb_at(pdrf) is not None
    if name == "gps_nan_jumps":
        return gps_at(pdrf) is not None
    return True


def variant_names(pdrf):
    return [n for n in VARIANTS[14 if pdrf >= 6 else 10] if variant_applies(n, pdrf)]


_bases = {}


def variant(name, pdrf, n, span):
    """(records, scale and offset) of variant name in point format pdrf,
    made from the first n points of pdal_autzen_trim(_7). Seeded by name and format: the same records on
    every run."""
    key = 14 if pdrf >= 6 else 10
    if key not in _bases:
        _, so, recs = las_records(data("las", "pdal_autzen_trim_7.las" if key == 14
                                       else "pdal_autzen_trim.las"))
        _bases[key] = so, recs
    so, recs = _bases[key]
    names = list(VARIANTS[key])
    rng = np.random.default_rng([34, pdrf, names.index(name)])
    b = convert(recs[:n], 7 if key == 14 else 3, pdrf)
    return np.ascontiguousarray(VARIANTS[key][name](b, pdrf, rng, span)), so


# ---- comparing ----

def dump_digest(path):
    """(exit code, sha256 of laszip_dump's output, its stderr)."""
    p = subprocess.Popen([laszip("laszip_dump"), path], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    h = hashlib.sha256()
    for block in iter(lambda: p.stdout.read(1 << 20), b""):
        h.update(block)
    err = p.stderr.read().decode(errors="replace").strip()
    return p.wait(), h.hexdigest(), err


def first_difference(a, b):
    """The first point whose laszip_dump lines differ between files a and
    b, as text."""
    pa = subprocess.Popen([laszip("laszip_dump"), a], stdout=subprocess.PIPE)
    pb = subprocess.Popen([laszip("laszip_dump"), b], stdout=subprocess.PIPE)
    i = 0
    try:
        while True:
            la, lb = pa.stdout.readline(), pb.stdout.readline()
            if la != lb:
                return "point %d: %r against %r" % (i, la.decode()[:160], lb.decode()[:160])
            if not la:
                return "no point differs"
            i += 1
    finally:
        pa.kill()
        pb.kill()
        pa.wait()
        pb.wait()


def laz_parts(path):
    """(LASzip VLR payload, point data, chunk table) of a LAZ file: the
    point data run from after the chunk table pointer to the table, the
    table to the EVLRs or the end of the file."""
    with open(path, "rb") as f:
        b = f.read()
    _, _, _, off = las_facts(b)
    vlr, p = None, struct.unpack_from("<H", b, 94)[0]
    for _ in range(struct.unpack_from("<I", b, 100)[0]):
        uid = b[p + 2:p + 18].rstrip(b"\0")
        rid, length = struct.unpack_from("<HH", b, p + 18)
        if uid == b"laszip encoded" and rid == 22204:
            vlr = b[p + 54:p + 54 + length]
        p += 54 + length
    table = struct.unpack_from("<q", b, off)[0]
    end = len(b)
    if (b[24], b[25]) >= (1, 4):
        evlr, nevlr = struct.unpack_from("<QI", b, 235)
        if nevlr and table < evlr <= len(b):
            end = evlr
    if table < off + 8 or table > end:  # no usable table (LASzip's empty files)
        return vlr, b[off + 8:end], b""
    return vlr, b[off + 8:table], b[table:end]


def without_evlrs(src):
    """src, or a copy without its EVLRs when it has some: laszip_enc (the
    LASzip library's writer) copies the header's EVLR count and offset but
    writes no EVLRs, and wpd refuses a file whose stale EVLR offset then
    lands inside the compressed points (as for any EVLR pointer into the
    points, docs/formats.md)."""
    with open(src, "rb") as f:
        b = bytearray(f.read())
    if (b[24], b[25]) < (1, 4) or not struct.unpack_from("<I", b, 243)[0]:
        return src
    pdrf, length, n, off = las_facts(b)
    struct.pack_into("<QI", b, 235, 0, 0)
    with open("no_evlrs.las", "wb") as f:
        f.write(b[:off + n * length])
    return "no_evlrs.las"


def same_records(path, want):
    """Whether the LAS file path holds exactly the records want."""
    try:
        got = las_records(path)[2]
    except (OSError, ValueError, struct.error):
        return False
    return got.shape == want.shape and np.array_equal(got, want)


def first_record_difference(path, want):
    got = las_records(path)[2]
    if got.shape != want.shape:
        return "records %s against %s" % (got.shape, want.shape)
    i = int(np.nonzero((got != want).any(1))[0][0])
    return "record %d: %s against %s" % (i, got[i].tobytes().hex(), want[i].tobytes().hex())


def check(src, chunk, tag):
    """Both directions and the bytes for one LAS file src at chunk points
    a chunk (0: LASzip's variable chunks, read by wpd only). Returns the
    problems found (empty: all agree).

    The points are compared as records, byte for byte: wpd writes the LAS
    records it decodes, and laszip_enc with compression 0 writes those
    LASzip decodes (it keeps the records of every file in ../shared/data
    byte for byte). laszip_dump's text only explains a difference."""
    problems = []
    want = las_records(src)[2]
    z = run(laszip("laszip_enc"), without_evlrs(src), "lz.laz", 1, chunk)
    if z.returncode:
        return ["%s: laszip_enc failed: %s" % (tag, z.stderr.strip())]
    r = run(WPD, "convert", "lz.laz", "back.las", "--force")
    if r.returncode:
        problems.append("%s: LASzip -> wpd: wpd refuses LASzip's LAZ: %s" %
                        (tag, r.stderr.strip()))
    elif not same_records("back.las", want):
        rc0, d0, _ = dump_digest(src)
        rcz, dz, errz = dump_digest("lz.laz")
        if (rcz, dz) != (rc0, d0):
            problems.append("%s: LASzip's own LAZ does not hold the LAS points: %s" %
                            (tag, errz or first_difference(src, "lz.laz")))
        rc, d, err = dump_digest("back.las")
        if (rc, d) != (rcz, dz) or (rcz, dz) == (rc0, d0):
            problems.append("%s: LASzip -> wpd: %s" % (tag, err or (
                first_difference("lz.laz", "back.las") if (rc, d) != (rcz, dz)
                else first_record_difference("back.las", want))))
    if chunk == 0:  # LASzip's variable chunks: wpd writes fixed ones only
        return problems
    env = dict(os.environ, WPD_TEST_LAZ_CHUNK=str(chunk))
    r = run(WPD, "convert", src, "own.laz", "--force", env=env)
    if r.returncode:
        return problems + ["%s: wpd cannot write LAZ: %s" % (tag, r.stderr.strip())]
    d = run(laszip("laszip_enc"), "own.laz", "own_back.las", 0)
    if d.returncode:
        problems.append("%s: wpd -> LASzip: LASzip refuses wpd's LAZ: %s" %
                        (tag, d.stderr.strip()))
    elif not same_records("own_back.las", want):
        problems.append("%s: wpd -> LASzip: %s (%s)" % (
            tag, first_record_difference("own_back.las", want),
            first_difference(src, "own.laz")))
    (v1, p1, t1), (v2, p2, t2) = laz_parts("lz.laz"), laz_parts("own.laz")
    if p1 != p2:
        at = next((i for i in range(min(len(p1), len(p2))) if p1[i] != p2[i]),
                  min(len(p1), len(p2)))
        problems.append("%s: point data differ: %d bytes (LASzip) against %d (wpd), first "
                        "at byte %d" % (tag, len(p1), len(p2), at))
    if t1 != t2:
        problems.append("%s: chunk tables differ: %s against %s" % (tag, t1[:16].hex(),
                                                                    t2[:16].hex()))
    if v1 is None or v2 is None or v1[:4] + v1[8:] != v2[:4] + v2[8:]:
        problems.append("%s: LASzip VLRs differ: %s against %s" % (
            tag, v1 and v1.hex(), v2 and v2.hex()))
    return problems


def data_las(folders, most=None):
    """LAS files of point format 0-3 or 6-8 in ../shared/data's folders
    (with most, those of at most that many points)."""
    out = []
    for folder in folders:
        for row in manifest(folder):
            path = os.path.join(DATA, folder, row["file"])
            if not row["file"].endswith(".las") or not os.path.exists(path):
                continue
            with open(path, "rb") as f:
                head = f.read(375)
            if (head[:4] == b"LASF" and len(head) >= 227 and head[104] & 0x3F in FORMATS and
                    (most is None or las_facts(head)[2] <= most)):
                out.append(path)
    return out


class Sweep:
    """Cases checked and problems found, for the tests' messages and the
    report."""

    def __init__(self):
        self.cases = self.points = 0
        self.files = set()
        self.problems = []

    def one(self, src, chunk, tag):
        with open(src, "rb") as f:
            n = las_facts(f.read(375))[2]
        found = check(src, chunk, tag)
        self.cases += 1
        self.points += n
        self.files.add(tag.split("@")[0])
        self.problems += found
        if SHOW:
            print("%-60s %9d points  %s" % (tag, n, "ok" if not found else found), flush=True)

    def verdict(self):
        return "%d cases (%d files and variants, %d points): %d problems%s" % (
            self.cases, len(self.files), self.points, len(self.problems),
            "".join("\n  " + p for p in self.problems[:20]))

    def variant(self, name, pdrf, n, span, chunks):
        recs, so = variant(name, pdrf, n, span)
        write_las("v.las", pdrf, recs, so)
        for chunk in chunks:
            self.one("v.las", chunk, "%s_%d@%d" % (name, pdrf, chunk))


def sweep_real(s, folders, small_chunks=True, paths=None):
    for path in paths if paths is not None else data_las(folders):
        name = "%s/%s" % (os.path.basename(os.path.dirname(path)), os.path.basename(path))
        s.one(path, 50000, "%s@50000" % name)
        with open(path, "rb") as f:
            n = las_facts(f.read(375))[2]
        if small_chunks and 0 < n <= 2000:
            s.one(path, 1, "%s@1" % name)
            s.one(path, 2, "%s@2" % name)


def sweep_big_layered(s):
    """The largest scan as point format 8 with 3 extra bytes and scanner
    channels 0-3 in runs: millions of layered points through every item's
    contexts."""
    scans = [p for p in data_las(("scans",)) if "nc_raleigh" in p]
    if not scans:
        return
    pdrf, so, recs = las_records(scans[0])
    rng = np.random.default_rng(8)
    r = with_extra(convert(recs, pdrf, 8), rng, 3)
    set_channels(r, runs(rng, len(r), [0, 1, 2, 3], 50))
    write_las("big8.las", 8, r, so)
    s.one("big8.las", 50000, "nc_raleigh_as_8_channels@50000")


# The sweep of the full tier: variants of 60,000 points (two chunks of
# 50,000, the second short), channels switching across 23,000-point runs.
SLOW_POINTS, SLOW_SPAN, SLOW_SMALL = 60000, 50000, 3000


def slow_chunks(name):
    if name in ("small_mixed", "empty"):
        return (1, 2, 50000)
    if name == "channels_random":
        return (50000, 7777, 0)
    if name == "channels_in_chunks":
        return (50000, 7777)
    return (50000,)


def sweep_variants(s):
    for pdrf in FORMATS:
        for name in variant_names(pdrf):
            s.variant(name, pdrf, SLOW_SMALL if name == "small_mixed" else SLOW_POINTS,
                      SLOW_SPAN, slow_chunks(name))


# The fast tier (make test): the same cases on a few thousand points, the
# chunks of 1 and 2 points on a few hundred, and the real files of at most
# FAST_FILE_POINTS points at LASzip's chunk size.
FAST_POINTS, FAST_SPAN, FAST_SMALL, FAST_FILE_POINTS = 3000, 1000, 300, 10000


def fast_chunks(name):
    if name == "small_mixed":
        return (1, 2, 50000)
    if name == "channels_random":  # 0: LASzip's variable chunks, read by wpd
        return (50000, FAST_SPAN, 0)
    if name == "channels_in_chunks":
        return (FAST_SPAN, 50000)
    return (50000,)


@pytest.mark.parametrize("pdrf,name", [(p, n) for p in FORMATS for n in variant_names(p)])
def test_laz_laszip_variant(pdrf, name):
    """A generated variant of a few thousand points (or a few hundred for
    chunks of 1 and 2 points) both ways and byte for byte."""
    laszip("laszip_enc")
    s = Sweep()
    s.variant(name, pdrf, FAST_SMALL if name == "small_mixed" else FAST_POINTS, FAST_SPAN,
              fast_chunks(name))
    assert not s.problems, s.verdict()


@pytest.mark.parametrize("pdrf", FORMATS)
def test_laz_laszip_small_files(pdrf):
    """The LAS files of ../shared/data/las and laz (their LAS twins) of
    point format pdrf and at most FAST_FILE_POINTS points: LASzip's LAZ
    reads in wpd to the original points, wpd's LAZ in LASzip, and wpd's
    LAZ is LASzip's but for the header."""
    laszip("laszip_enc")
    paths = [p for p in data_las(("las", "laz"), FAST_FILE_POINTS) if head_facts(p)[0] == pdrf]
    s = Sweep()
    sweep_real(s, None, small_chunks=False, paths=paths)
    assert not s.problems, s.verdict()
    assert s.cases >= 1, s.verdict()


@pytest.mark.slow
def test_laz_laszip_agree_both_ways():
    """Every LAS file of point format 0-3 and 6-8 of ../shared/data/las and
    laz (their LAS twins; those of up to 2,000 points also in chunks of 1
    and 2 points), and the generated variants at 60,000 points (two
    chunks; 7,777-point chunks and LASzip's variable ones too): LASzip's
    LAZ reads in wpd to the original points, wpd's LAZ in LASzip, and
    wpd's LAZ is LASzip's but for the header."""
    laszip("laszip_enc")
    s = Sweep()
    sweep_real(s, ("las", "laz"))
    sweep_variants(s)
    assert not s.problems, s.verdict()
    assert s.cases >= 240 and len(s.files) >= 120, s.verdict()


@pytest.mark.slow
def test_laz_laszip_agree_both_ways_scans():
    """The same for the scans of ../shared/data/scans (LAS, up to 2.3
    million points) and the largest as point format 8 with scanner
    channels."""
    laszip("laszip_enc")
    s = Sweep()
    sweep_real(s, ("scans",), small_chunks=False)
    sweep_big_layered(s)
    assert not s.problems, s.verdict()
    assert s.cases >= 6, s.verdict()


def test_laz_laszip_gps_negative_zero():
    """The one difference known: LASzip compares the GPS times of point
    formats 6-10 as doubles, so -0.0 after 0.0 is "unchanged" to it and
    its LAZ reads back 0.0. wpd codes the change (lossless): its LAZ reads
    in LASzip to the original, and its bytes differ from LASzip's there;
    LASzip's LAZ reads in wpd as in LASzip."""
    laszip("laszip_enc")
    _, so, recs = las_records(data("las", "pdal_autzen_trim_7.las"))
    r = recs[:100].copy()
    put(r, 22, np.where(np.arange(100) % 2, -0.0, 0.0), "<f8")
    write_las("z.las", 7, r, so)
    kinds = sorted(p.split(": ")[1] for p in check("z.las", 50000, "z"))
    assert kinds == ["LASzip's own LAZ does not hold the LAS points", "chunk tables differ",
                     "point data differ"], kinds


def test_laz_laszip_file_of_wpd_las_does_not_warn():
    """LASzip's LAZ of a LAS that says "wpd" as generating software (as
    every LAS of wpd before 0.2.0 does), scanner channels changing within
    the chunk, colour and extra bytes: no old-wpd warning, even with
    "wpd" in its header, since its LASzip VLR is LASzip's, not wpd's."""
    laszip("laszip_enc")
    recs, so = variant("extra_bytes", 7, 3000, 1000)
    write_las("v.las", 7, recs, so)
    with open("v.las", "r+b") as f:
        f.seek(58)
        f.write(b"wpd".ljust(32, b"\0"))
    assert run(laszip("laszip_enc"), "v.las", "lz.laz", 1).returncode == 0
    with open("lz.laz", "r+b") as f:
        f.seek(58)
        f.write(b"wpd".ljust(32, b"\0"))
    for cmd in (("info", "lz.laz"), ("convert", "lz.laz", "o.las")):
        p = run(WPD, *cmd)
        assert p.returncode == 0 and "older wpd" not in p.stderr, (cmd, p.stderr)
    assert same_records("o.las", recs)


def test_laz_laszip_refused_laz_reads_after_laszip():
    """The LAZ files wpd refuses and what docs/formats.md tells to do with
    them: LASzip 1.x items (pdal_simple-laszip-compressor-version-1.2r0)
    recompressed by a current LASzip read in wpd to the records LASzip
    decodes (pdal_simple.las's); waveform packets (rlas_fwf, format 4)
    decompressed by LASzip read in wpd as LAS, the packet descriptors kept
    record for record."""
    laszip("laszip_enc")
    v1 = data("laz", "pdal_simple-laszip-compressor-version-1.2r0.laz")
    fwf = data("laz", "rlas_fwf.laz")
    for src in (v1, fwf):
        assert run(WPD, "info", src).returncode == 2, src
    assert run(laszip("laszip_enc"), v1, "v2.laz", 1).returncode == 0
    assert run(laszip("laszip_enc"), v1, "v1.las", 0).returncode == 0
    r = run(WPD, "convert", "v2.laz", "v2.las")
    assert r.returncode == 0, r.stderr
    want = las_records("v1.las")[2]
    assert same_records("v2.las", want) and same_records(data("las", "pdal_simple.las"), want)
    assert run(laszip("laszip_enc"), fwf, "fwf.las", 0).returncode == 0
    r = run(WPD, "convert", "fwf.las", "fwf_out.las")
    assert r.returncode == 0, r.stderr
    assert same_records("fwf_out.las", las_records("fwf.las")[2])
    assert las_records("fwf.las")[0] == 4


def test_laz_laszip_bad_files():
    """The damaged LAS files of ../shared/data/bad: wpd refuses what LASzip
    cannot read either (a file cut short, a VLR count of a billion) and
    refuses pdal_bad_vlr_count.las, which LASzip reads past its VLR count
    (docs/formats.md, the strict cases)."""
    laszip("laszip_dump")
    seen = {}
    for row in manifest("bad"):
        if not row["file"].endswith(".las"):
            continue
        path = data("bad", row["file"])
        rc, d, _ = dump_digest(path)
        w = run(WPD, "convert", path, "b.las", "--force")
        if w.returncode:
            seen[row["file"]] = "both refuse" if rc else "wpd refuses"
        else:
            rcw, dw, _ = dump_digest("b.las")
            seen[row["file"]] = ("LASzip refuses" if rc else
                                 "same points" if (rcw, dw) == (0, d) else "different points")
    assert seen == {"pdal_1.2-with-color-clipped.las": "both refuse",
                    "pdal_garbage_nVariableLength.las": "both refuse",
                    "pdal_bad_vlr_count.las": "wpd refuses"}, seen


if __name__ == "__main__":
    import tempfile
    os.chdir(tempfile.mkdtemp(prefix="wpd-laszip-"))
    SHOW = SHOW or "1"
    s = Sweep()
    if sys.argv[1:] == ["scans"]:
        sweep_real(s, ("scans",), small_chunks=False)
        sweep_big_layered(s)
    else:
        sweep_real(s, ("las", "laz"))
        sweep_variants(s)
    print(s.verdict())
