"""Independent readers of LAS and PLY, written from the specifications, used
as oracles by the end-to-end tests (they share no code with wpd)."""
import struct

import numpy as np

PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
    "int64": "i8", "uint64": "u8",
}


def read_las(path):
    """Header facts, VLRs/EVLRs (user, id, payload) and the raw point block."""
    with open(path, "rb") as f:
        b = f.read()
    assert b[:4] == b"LASF", path
    h = {}
    h["version"] = (b[24], b[25])
    h["header_size"], h["offset_to_points"], h["nvlr"] = struct.unpack_from("<HII", b, 94)
    h["pdrf"], h["record_length"], legacy = struct.unpack_from("<BHI", b, 104)
    h["scale"] = struct.unpack_from("<3d", b, 131)
    h["offset"] = struct.unpack_from("<3d", b, 155)
    mx, mn, my, mny, mz, mnz = struct.unpack_from("<6d", b, 179)
    h["min"], h["max"] = (mn, mny, mnz), (mx, my, mz)
    count = legacy
    evlrs = []
    if h["version"] >= (1, 4) and h["header_size"] >= 375:
        start_evlr, nevlr, count64 = struct.unpack_from("<QIQ", b, 235)
        count = count64 or legacy
        pos = start_evlr
        for _ in range(nevlr if start_evlr else 0):
            user = b[pos + 2:pos + 18].split(b"\0")[0]
            rid, length = struct.unpack_from("<HQ", b, pos + 18)
            evlrs.append((user, rid, b[pos + 60:pos + 60 + length]))
            pos += 60 + length
    h["count"] = count
    vlrs, pos = [], h["header_size"]
    for _ in range(h["nvlr"]):
        user = b[pos + 2:pos + 18].split(b"\0")[0]
        rid, length = struct.unpack_from("<HH", b, pos + 18)
        vlrs.append((user, rid, b[pos + 54:pos + 54 + length]))
        pos += 54 + length
    start = h["offset_to_points"]
    h["points"] = b[start:start + count * h["record_length"]]
    h["vlrs"], h["evlrs"] = vlrs, evlrs
    return h


def las_xyz_int(h):
    """X, Y, Z integer arrays of a read_las() result."""
    rec = np.frombuffer(h["points"], dtype=np.uint8).reshape(-1, h["record_length"])
    return rec[:, :12].copy().view("<i4").reshape(-1, 3)


def read_ply(path):
    """(header dict, numpy structured array of the vertex element)."""
    with open(path, "rb") as f:
        raw = f.read()
    end = raw.index(b"end_header")
    nl = raw.index(b"\n", end)
    lines = raw[:end].decode("latin-1").replace("\r", "").split("\n")
    fmt, elements, comments = None, [], []
    for line in lines:
        t = line.split()
        if not t:
            continue
        if t[0] == "format":
            fmt = t[1]
        elif t[0] == "comment":
            comments.append(line[8:])
        elif t[0] == "element":
            elements.append((t[1], int(t[2]), []))
        elif t[0] == "property":
            elements[-1][2].append(("list", t[2], t[3], t[4]) if t[1] == "list" else (t[1], t[2]))
    body = raw[nl + 1:]
    end_char = "<" if fmt != "binary_big_endian" else ">"
    tokens = body.split() if fmt == "ascii" else None
    pos = 0
    for name, count, props in elements:
        scalar = [p for p in props if p[0] != "list"]
        if name == "vertex":
            dtype = np.dtype([(p[1], end_char + PLY_TYPES[p[0]]) for p in scalar])
            if fmt == "ascii":
                vals = np.array(tokens[pos:pos + count * len(scalar)], dtype=np.float64)
                arr = np.zeros(count, dtype=dtype.newbyteorder("<"))
                for i, p in enumerate(scalar):
                    arr[p[1]] = vals[i::len(scalar)]
                return {"format": fmt, "elements": elements, "comments": comments,
                        "props": scalar}, arr
            arr = np.frombuffer(body, dtype=dtype, count=count, offset=pos)
            return {"format": fmt, "elements": elements, "comments": comments,
                    "props": scalar}, arr
        for _ in range(count):  # skip an element before the vertex element
            for p in props:
                if fmt == "ascii":
                    n = int(tokens[pos]) if p[0] == "list" else 0
                    pos += 1 + n if p[0] == "list" else 1
                else:
                    if p[0] == "list":
                        ct = np.dtype(end_char + PLY_TYPES[p[1]])
                        n = int(np.frombuffer(body, ct, 1, pos)[0])
                        pos += ct.itemsize + n * np.dtype(PLY_TYPES[p[2]]).itemsize
                    else:
                        pos += np.dtype(PLY_TYPES[p[0]]).itemsize
    raise AssertionError(path + ": no vertex element")
