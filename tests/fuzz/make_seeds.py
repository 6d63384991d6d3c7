#!/usr/bin/env python3
"""Builds the fuzz seed corpora (build/fuzz/seeds/{ply,las,laz}) from the shared
test data, small enough that every execution is fast.

  make_seeds.py DATA_DIR OUT_DIR [MAX_LEN]

PLY: every file under DATA_DIR/{ply,scans,bad} is parsed, each element cut
to its first items, and written again in all three encodings (ascii,
binary_little_endian, binary_big_endian) with the header's counts patched,
so every schema in the data is seen in every encoding. Files that do not
parse (the bad/ ones) are kept as their first MAX_LEN bytes.

LAS: every file under DATA_DIR/{las,scans,bad} is cut to its header, the
VLRs that fit, a few hundred points and its EVLRs, with the counts and
offsets patched so the seed is still valid. Malformed or compressed files
are kept as their first MAX_LEN bytes. PDRFs the data lacks are covered by
synthetic files: one per PDRF 0-10, with an Extra Bytes VLR (scaled,
array and undocumented extra bytes) and, for LAS 1.3/1.4, an EVLR.

LAZ: every file under DATA_DIR/laz, whole when it is small, else cut to
the first points of its first chunk (laz_seed): decoding is the cost of an
execution, so the seeds hold few points. Then the committed seeds of
tests/fuzz/seeds-laz (make_laz_seeds.py: LASzip's LAZ of synthetic points
for what the data lacks - scanner channels changing within a chunk with
colour, NIR and extra bytes, small chunks, formats 0-3 - and an older
wpd's file), copied as they are.

The seeds made here are build products: never commit them (the data's
licences are the data's). Nothing here is random: the same data gives the
same seeds.
"""
import hashlib
import os
import random
import struct
import sys

PLY_TYPES = {  # name -> (struct code, canonical name)
    "char": "b", "int8": "b", "uchar": "B", "uint8": "B",
    "short": "h", "int16": "h", "ushort": "H", "uint16": "H",
    "int": "i", "int32": "i", "uint": "I", "uint32": "I",
    "float": "f", "float32": "f", "double": "d", "float64": "d",
    "int64": "q", "long": "q", "uint64": "Q", "ulong": "Q",
}
ENCODINGS = ("ascii", "binary_little_endian", "binary_big_endian")
VERTEX_ITEMS = 300   # vertices kept per PLY seed (fewer if MAX_LEN needs it)
OTHER_ITEMS = 40     # items kept of other PLY elements
LAS_POINTS = 300     # point records kept per LAS seed
LAZ_SMALL = 4096     # LAZ files up to this size are seeds as they are
LAZ_POINTS = 200     # points kept of larger LAZ files


class Bad(Exception):
    pass


# ---------------------------------------------------------------- PLY

def ply_parse(data):
    """Returns (encoding, header lines to keep, elements) where each element
    is {name, props: [(name, type, count_type or None)], items: [...]}, or
    raises Bad."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise Bad("no header")
    nl = data.find(b"\n", end)
    if nl < 0:
        raise Bad("no newline after end_header")
    body = nl + 1
    lines = data[:end].decode("ascii").replace("\r", "").split("\n")
    enc, keep, elems = None, [], []
    for line in lines[1:]:
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            enc = w[1]
        elif w[0] in ("comment", "obj_info"):
            keep.append(line)
        elif w[0] == "element":
            elems.append({"name": w[1], "count": int(w[2]), "props": [], "items": []})
        elif w[0] == "property":
            if w[1] == "list":
                elems[-1]["props"].append((w[4], PLY_TYPES[w[3]], PLY_TYPES[w[2]]))
            else:
                elems[-1]["props"].append((w[2], PLY_TYPES[w[1]], None))
        else:
            raise Bad("keyword " + w[0])
    if enc not in ENCODINGS:
        raise Bad("format")
    if enc == "ascii":
        toks = data[body:].split()
        pos = 0

        def take(code):
            nonlocal pos
            t = toks[pos]
            pos += 1
            return float(t) if code in "fd" else int(t)
    else:
        bo = "<" if enc == "binary_little_endian" else ">"
        pos = body

        def take(code):
            nonlocal pos
            v, = struct.unpack_from(bo + code, data, pos)
            pos += struct.calcsize(code)
            return v
    # Elements up to the vertex element are walked in full (items vary in
    # size); after it, the walk stops at the first element cut short and
    # the rest keep no items (the reader never reads past the vertices).
    past_vertex = False
    for e in elems:
        limit = VERTEX_ITEMS if e["name"] == "vertex" else OTHER_ITEMS
        past_vertex |= e["name"] == "vertex"
        for i in range(e["count"]):
            if i == limit and past_vertex:
                return enc, keep, elems
            item = []
            for name, code, count_code in e["props"]:
                if count_code:
                    n = take(count_code)
                    item.append([take(code) for _ in range(n)])
                else:
                    item.append(take(code))
            if i < limit:
                e["items"].append(item)
    return enc, keep, elems


def ply_value(v, code):
    if code in "fd":
        if code == "f":
            v = struct.unpack("<f", struct.pack("<f", v))[0]
        return repr(v)
    return str(v)


def ply_write(enc, keep, elems, nitems):
    """The PLY file holding the first nitems(e) items of each element."""
    head = ["ply", "format %s 1.0" % enc] + keep
    names = {v: k for k, v in PLY_TYPES.items() if k in
             ("char", "uchar", "short", "ushort", "int", "uint", "float", "double",
              "int64", "uint64")}
    for e in elems:
        head.append("element %s %d" % (e["name"], nitems(e)))
        for name, code, count_code in e["props"]:
            if count_code:
                head.append("property list %s %s %s" % (names[count_code], names[code], name))
            else:
                head.append("property %s %s" % (names[code], name))
    head.append("end_header")
    out = bytearray(("\n".join(head) + "\n").encode("ascii"))
    bo = "<" if enc == "binary_little_endian" else ">"
    for e in elems:
        for item in e["items"][:nitems(e)]:
            if enc == "ascii":
                words = []
                for v, (_, code, count_code) in zip(item, e["props"]):
                    if count_code:
                        words.append(str(len(v)))
                        words += [ply_value(x, code) for x in v]
                    else:
                        words.append(ply_value(v, code))
                out += (" ".join(words) + "\n").encode("ascii")
            else:
                for v, (_, code, count_code) in zip(item, e["props"]):
                    if count_code:
                        out += struct.pack(bo + count_code, len(v))
                        out += b"".join(struct.pack(bo + code, x) for x in v)
                    else:
                        out += struct.pack(bo + code, v)
    return bytes(out)


def ply_seeds(data, max_len):
    """All seeds made from one PLY file."""
    try:
        enc, keep, elems = ply_parse(data)
    except (Bad, ValueError, IndexError, KeyError, struct.error, UnicodeDecodeError):
        return [data[:max_len]]
    seeds = []
    for out_enc in ENCODINGS:
        k = max(len(e["items"]) for e in elems) if elems else 0
        while True:
            blob = ply_write(out_enc, keep, elems, lambda e: min(len(e["items"]), k))
            if len(blob) <= max_len or k <= 1:
                break
            k //= 2
        seeds.append(blob[:max_len])
    return seeds


def ply_synthetic():
    """Vertex elements the data lacks: every scalar type, list properties
    inside the vertex element (the item-by-item path), an element with lists
    before the vertices."""
    rnd = random.Random(6)
    types = ["b", "B", "h", "H", "i", "I", "f", "d", "q", "Q"]
    lim = {"b": 127, "B": 255, "h": 32767, "H": 65535, "i": 2**31 - 1, "I": 2**32 - 1,
           "q": 2**63 - 1, "Q": 2**64 - 1}

    def val(code):
        if code in "fd":
            return rnd.uniform(-1e3, 1e3)
        lo = 0 if code.isupper() else -lim[code] - 1
        return rnd.randint(lo, lim[code])
    all_types = [("x", "d", None), ("y", "f", None), ("z", "i", None)] + \
                [("p_" + t.replace("Q", "uq").replace("q", "sq"), t, None) for t in types]
    with_list = [("x", "f", None), ("idx", "i", "B"), ("y", "f", None), ("z", "f", None),
                 ("tags", "h", "H")]
    no_z = [("x", "h", None), ("y", "B", None), ("w", "d", None)]
    out = []
    for props, before in ((all_types, None), (with_list, None), (no_z, None),
                          (with_list, [("vertex_indices", "I", "B")])):
        elems = []
        if before:
            elems.append({"name": "face", "props": before,
                          "items": [[[rnd.randint(0, 9) for _ in range(rnd.randint(0, 4))]]
                                    for _ in range(7)]})
        items = []
        for _ in range(40):
            items.append([[val(c) for _ in range(rnd.randint(0, 3))] if cc else val(c)
                          for _, c, cc in props])
        elems.append({"name": "vertex", "props": props, "items": items})
        for enc in ENCODINGS:
            out.append(ply_write(enc, ["comment synthetic fuzz seed"], elems,
                                 lambda e: len(e["items"])))
    # Headers read with warnings (docs/formats.md, PLY): Blender 2.4x's
    # free-text line, a blank line, the format line again.
    for enc in ENCODINGS:
        odd = ["Created by Blender3D 247 - www.blender.org, source file: seed.blend", "",
               "format %s 1.0" % enc]
        out.append(ply_write(enc, odd, elems, lambda e: len(e["items"])))
    return out


# ---------------------------------------------------------------- LAS

def laz_seed(data, max_len):
    """A LAZ file small enough to decode fast under the sanitizers: whole
    when it has at most LAZ_SMALL bytes (its chunk table then valid), else
    cut to LAZ_POINTS points of its first chunk: the counts patched and the
    bytes those points need kept (three times the file's mean per point, plus a
    margin), the chunk table offset made invalid so that the reader takes
    the sequential path (with its warning). Files the cut cannot apply to
    are kept as their first bytes."""
    if len(data) <= LAZ_SMALL:
        return data
    try:
        off, = struct.unpack_from("<I", data, 96)
        rl, = struct.unpack_from("<H", data, 105)
        count, = struct.unpack_from("<I", data, 107)
        if data[25] >= 4:
            count = struct.unpack_from("<Q", data, 247)[0] or count
    except struct.error:
        return data[:max_len]
    if count <= LAZ_POINTS or off + 8 > len(data):
        return data[:max_len]
    per_point = (len(data) - off) / count
    keep = off + 8 + rl + int(3 * per_point * LAZ_POINTS) + 1024
    seed = bytearray(data[:min(keep, max_len, len(data))])
    struct.pack_into("<q", seed, off, 0)  # no chunk table: read sequentially
    if struct.unpack_from("<I", seed, 107)[0]:
        struct.pack_into("<I", seed, 107, LAZ_POINTS)
    if seed[25] >= 4:
        struct.pack_into("<Q", seed, 247, LAZ_POINTS)
        struct.pack_into("<QI", seed, 235, 0, 0)  # EVLRs were cut off
    return bytes(seed)


def las_seed(data, max_len):
    """The file cut to header, VLRs that fit, LAS_POINTS points and its
    EVLRs, counts and offsets patched; raises Bad when it is malformed."""
    if len(data) < 227 or data[:4] != b"LASF" or data[24] != 1 or data[25] > 4:
        raise Bad("header")
    minor = data[25]
    hs, = struct.unpack_from("<H", data, 94)
    off, nvlr = struct.unpack_from("<II", data, 96)
    pdrf, rl = data[104], struct.unpack_from("<H", data, 105)[0]
    if pdrf & 0xC0 or hs > off or off > len(data) or rl == 0 or hs > len(data):
        raise Bad("layout")
    count, = struct.unpack_from("<I", data, 107)
    evlr_start, nevlr = 0, 0
    if minor >= 4:
        evlr_start, nevlr, c64 = struct.unpack_from("<QIQ", data, 235)
        count = c64 or count
    elif minor == 3:
        evlr_start, = struct.unpack_from("<Q", data, 227)
        nevlr = 1 if evlr_start else 0
    # VLRs: keep those that fit in half the budget.
    vlrs, pos = [], hs
    for _ in range(nvlr):
        if pos + 54 > off:
            raise Bad("vlr")
        ln, = struct.unpack_from("<H", data, pos + 20)
        if pos + 54 + ln > off:
            raise Bad("vlr")
        if hs + sum(map(len, vlrs)) + 54 + ln <= max_len // 2:
            vlrs.append(data[pos:pos + 54 + ln])
        pos += 54 + ln
    pad = data[pos:off] if len(vlrs) == nvlr else b""
    evlrs, epos = [], evlr_start
    for _ in range(nevlr):
        if epos + 60 > len(data):
            raise Bad("evlr")
        ln, = struct.unpack_from("<Q", data, epos + 20)
        if epos + 60 + ln > len(data):
            raise Bad("evlr")
        evlrs.append(data[epos:epos + 60 + ln])
        epos += 60 + ln
    evlr_bytes = sum(map(len, evlrs))
    if evlr_bytes > max_len // 4:
        evlrs, evlr_bytes = [], 0
    prefix_len = hs + sum(map(len, vlrs)) + len(pad)
    room = max(0, max_len - prefix_len - evlr_bytes) // rl
    avail = (len(data) - off) // rl
    k = min(count, LAS_POINTS, room, avail)
    head = bytearray(data[:hs])
    new_off = prefix_len
    struct.pack_into("<II", head, 96, new_off, len(vlrs))
    legacy, = struct.unpack_from("<I", head, 107)
    struct.pack_into("<I", head, 107, k if legacy else 0)
    new_evlr = new_off + k * rl if evlrs else 0
    if minor >= 4:
        struct.pack_into("<QIQ", head, 235, new_evlr, len(evlrs), k)
    elif minor == 3:
        struct.pack_into("<Q", head, 227, new_evlr)
    return bytes(head) + b"".join(vlrs) + pad + data[off:off + k * rl] + b"".join(evlrs)


PDRF_SIZE = [20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67]


def extra_descriptor(data_type, options, name, scale=0.0, offset=0.0):
    d = bytearray(192)
    d[2], d[3] = data_type, options
    d[4:4 + len(name)] = name.encode()
    struct.pack_into("<ddd", d, 112, scale, scale, scale)
    struct.pack_into("<ddd", d, 136, offset, offset, offset)
    return bytes(d)


def vlr(user, rec, payload, extended=False):
    h = bytearray(60 if extended else 54)
    h[2:2 + len(user)] = user.encode()
    struct.pack_into("<H", h, 18, rec)
    if extended:
        struct.pack_into("<Q", h, 20, len(payload))
        h[28:28 + 11] = b"fuzz seed  "
    else:
        struct.pack_into("<H", h, 20, len(payload))
        h[22:22 + 11] = b"fuzz seed  "
    return bytes(h) + payload


def las_synthetic(pdrf, minor, npoints=40):
    """A small valid LAS 1.minor file of PDRF pdrf with described, array,
    undocumented and undescribed extra bytes, and an EVLR (1.3: waveform
    data packets; 1.4: a WKT record)."""
    rnd = random.Random(pdrf * 10 + minor)
    desc = (extra_descriptor(9, 0, "amplitude") +
            extra_descriptor(3, 0x18, "scaled", 0.01, 5.0) +
            extra_descriptor(13, 0x08, "pair", 0.5) +
            extra_descriptor(0, 3, ""))
    extra = 4 + 2 + 4 + 3 + 2  # the last 2 bytes are not described
    rl = PDRF_SIZE[pdrf] + extra
    vlrs = vlr("LASF_Spec", 4, desc) + vlr("LASF_Projection", 2112, b"GEOGCS[]\0")
    hs = {2: 227, 3: 235, 4: 375}[minor]
    off = hs + len(vlrs)
    points = bytearray()
    for _ in range(npoints):
        rec = bytearray(rnd.getrandbits(8) for _ in range(rl))
        struct.pack_into("<iii", rec, 0, rnd.randint(-10**6, 10**6),
                         rnd.randint(-10**6, 10**6), rnd.randint(-10**4, 10**4))
        points += rec
    if minor == 3:
        evlrs = vlr("LASF_Spec", 65535, bytes(64), extended=True)
    elif minor == 4:
        evlrs = vlr("LASF_Projection", 2112, b"COMPD_CS[]\0", extended=True)
    else:
        evlrs = b""
    h = bytearray(hs)
    h[0:4] = b"LASF"
    h[24], h[25] = 1, minor
    h[26:26 + 9] = b"fuzz seed"
    struct.pack_into("<HIIBHI", h, 94, hs, off, 2, pdrf, rl, npoints if pdrf < 6 else 0)
    struct.pack_into("<ddd", h, 131, 0.01, 0.01, 0.001)
    struct.pack_into("<ddd", h, 155, 1000.0, -2000.0, 0.0)
    struct.pack_into("<dddddd", h, 179, 2e4, -2e4, 2e4, -2e4, 10.0, -10.0)
    evlr_at = off + len(points) if evlrs else 0
    if minor == 3:
        struct.pack_into("<Q", h, 227, evlr_at)
    elif minor == 4:
        struct.pack_into("<QIQ", h, 235, evlr_at, 1, npoints)
    return bytes(h) + vlrs + bytes(points) + evlrs


# ---------------------------------------------------------------- main

def files(data_dir, folders, ext):
    for folder in folders:
        d = os.path.join(data_dir, folder)
        if not os.path.isdir(d):
            continue
        for name in sorted(os.listdir(d)):
            if name.lower().endswith(ext):
                yield name, os.path.join(d, name)


def save(out_dir, seeds, seen):
    """Writes each new seed as <sha1>.<ext>-less file name; returns the count."""
    n = 0
    for blob in seeds:
        h = hashlib.sha1(blob).hexdigest()
        if blob and h not in seen:
            seen.add(h)
            with open(os.path.join(out_dir, h), "wb") as f:
                f.write(blob)
            n += 1
    return n


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: make_seeds.py DATA_DIR OUT_DIR [MAX_LEN]")
    data_dir, out_dir = sys.argv[1], sys.argv[2]
    max_len = int(sys.argv[3]) if len(sys.argv) > 3 else 65536
    counts = {}
    for kind in ("ply", "las", "laz"):
        d = os.path.join(out_dir, kind)
        os.makedirs(d, exist_ok=True)
        for old in os.listdir(d):
            os.remove(os.path.join(d, old))
        seen = set()
        n = 0
        if kind == "laz":
            for _, path in files(data_dir, ("laz",), ".laz"):
                with open(path, "rb") as f:
                    n += save(d, [laz_seed(f.read(), max_len)], seen)
            for _, path in files(os.path.dirname(os.path.abspath(__file__)), ("seeds-laz",),
                                 ".laz"):
                with open(path, "rb") as f:
                    n += save(d, [f.read()[:max_len]], seen)
        elif kind == "ply":
            for _, path in files(data_dir, ("ply", "scans", "bad"), ".ply"):
                with open(path, "rb") as f:
                    n += save(d, ply_seeds(f.read(), max_len), seen)
            n += save(d, ply_synthetic(), seen)
        else:
            for _, path in files(data_dir, ("las", "scans", "bad"), (".las", ".laz")):
                with open(path, "rb") as f:
                    data = f.read()
                try:
                    seed = las_seed(data, max_len)
                except (Bad, struct.error):
                    seed = data[:max_len]
                n += save(d, [seed], seen)
            for pdrf in range(11):
                minors = [2, 4] if pdrf < 4 else [3, 4] if pdrf < 6 else [4]
                n += save(d, [las_synthetic(pdrf, m) for m in minors], seen)
        counts[kind] = n
    print("seeds: %d ply, %d las, %d laz (max %d bytes) in %s"
          % (counts["ply"], counts["las"], counts["laz"], max_len, out_dir))


if __name__ == "__main__":
    main()
