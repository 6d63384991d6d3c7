"""LAZ output (issue 13, the writer): `wpd convert` and `wpd resample` to
.laz give files that decode - with our reader and with the independent
decoder ../shared/tools/laz2las.js (npm laz-perf) - to exactly the LAS
file wpd writes for the same run; the chunk table and the LASzip VLR are
those of the specification; point formats 0-3 use the point-wise
compressor, 6-8 the layered one (PLY inputs, laid out as 6-8, included);
4, 5, 9 and 10 (waveform) are refused in one line and leave no file.

laz2las.js needs node and laz-perf 0.0.7: LAZPERF_NODE_PATH names the
node_modules folder holding it (default build/npm/node_modules, where
`make test` installs it, or ../npm/node_modules beside the repository);
without node or laz-perf those checks SKIP, saying so."""
import json
import os
import re
import shutil
import struct
import subprocess

import pytest

from harness import DATA, REPO, Skip, data, manifest, slow, wpd
from test_laz import records

LAZ2LAS = os.path.join(DATA, "..", "tools", "laz2las.js")
NODE_PATH = os.environ.get("LAZPERF_NODE_PATH") or next(
    (p for p in (os.path.join(REPO, "build", "npm", "node_modules"),
                 os.path.join(REPO, "..", "npm", "node_modules"))
     if os.path.isdir(os.path.join(p, "laz-perf"))),
    os.path.join(REPO, "build", "npm", "node_modules"))


def laz2las(laz, las):
    """Decodes laz with laz-perf into las; Skip when it cannot run here."""
    if not shutil.which("node"):
        raise Skip("SKIP laz2las.js: node is not installed")
    if not os.path.isdir(os.path.join(NODE_PATH, "laz-perf")):
        raise Skip("SKIP laz2las.js: no laz-perf in %s (set LAZPERF_NODE_PATH)" % NODE_PATH)
    if not os.path.exists(LAZ2LAS):
        raise Skip("SKIP laz2las.js: missing " + LAZ2LAS)
    p = subprocess.run(["node", LAZ2LAS, laz, las], capture_output=True, text=True,
                       env=dict(os.environ, NODE_PATH=NODE_PATH))
    assert p.returncode == 0, (laz, p.stdout, p.stderr)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def laszip_vlr(b):
    """The LASzip VLR payload of LAZ bytes b, or None."""
    p, n = struct.unpack_from("<H", b, 94)[0], struct.unpack_from("<I", b, 100)[0]
    for _ in range(n):
        uid = b[p + 2:p + 18].rstrip(b"\0")
        rid, length = struct.unpack_from("<HH", b, p + 18)
        if uid == b"laszip encoded" and rid == 22204:
            return b[p + 54:p + 54 + length]
        p += 54 + length
    return None


def check_same_as_las(laz, las, whole=True):
    """laz decodes (laz-perf, then our reader) to the records of las; with
    whole, laz-perf's file is las byte for byte (laz2las.js keeps the
    header, so everything but the compression is then proven equal)."""
    laz2las(laz, "js.las")
    if whole:
        assert read("js.las") == read(las), (laz, las)
    assert records("js.las") == records(las), (laz, las)
    wpd("convert", laz, "own.las", "--force")
    assert read("own.las") == read(las), (laz, las)


def readable_inputs():
    """Every LAS of ../shared/data/las and every LAZ of ../shared/data/laz
    with point format 0-3 or 6-8 that wpd reads."""
    out = []
    for folder, ext in (("las", ".las"), ("laz", ".laz")):
        for row in manifest(folder):
            m = re.search(r"PDRF (\d+)", row["format"])
            if row["file"].endswith(ext) and m and int(m.group(1)) in (0, 1, 2, 3, 6, 7, 8):
                out.append(data(folder, row["file"]))
    return out


def convert_matches_las_output(path):
    """path converted to .laz decodes with laz-perf (and our reader) to the
    LAS file the same convert writes. False for inputs wpd refuses
    (LASzip 1.x, waveform: test_laz.py's); True for layered output."""
    if wpd("convert", path, "ref.las", "--force", check=False).returncode:
        return False
    wpd("convert", path, "out.laz", "--force")
    b = read("out.laz")
    assert b[104] & 0x80 and laszip_vlr(b) is not None, path
    check_same_as_las("out.laz", "ref.las")
    return True


def one_input_per_format():
    """For each point format 0-3 and 6-8, the input of readable_inputs()
    nearest to 5,000 points among those of at least 1,000 (if any): the
    fast tier's laz-perf check."""
    best = {}
    for path in readable_inputs():
        with open(path, "rb") as f:
            b = f.read(375)
        n = struct.unpack_from("<I", b, 107)[0]
        if (b[24], b[25]) >= (1, 4) and len(b) >= 255:
            n = struct.unpack_from("<Q", b, 247)[0] or n
        pdrf = b[104] & 0x3F
        score = abs(n - 5000) + (0 if n >= 1000 else 1 << 40)
        if score < best.get(pdrf, (1 << 62, None))[0]:
            best[pdrf] = (score, path)
    return [best[k][1] for k in sorted(best)]


def test_laz_convert_one_file_per_format_matches_its_las_output():
    """laz-perf as a second decoder in the fast tier: one file of each
    point format 0-3 and 6-8 (LASzip itself: test_laz_laszip.py)."""
    paths = one_input_per_format()
    assert len(paths) == 7, paths
    for path in paths:
        assert convert_matches_las_output(path), path


@pytest.mark.slow
def test_laz_convert_every_format_0_3_6_8_file_matches_its_las_output():
    done = layered = 0
    for path in readable_inputs():
        if not convert_matches_las_output(path):
            continue
        done += 1
        layered += read("out.laz")[104] & 0x7F >= 6
    assert done >= 45 and layered >= 15, (done, layered)


def test_laz_layered_chunks_from_ply():
    """A PLY input (laid out as point format 6-8) to .laz: the layered
    compressor over 3 chunks, its table and VLR; decodes with laz-perf to
    the LAS the same convert writes, and back to the same PLY."""
    wpd("synth", "-n", 120001, "-o", "s.ply")
    wpd("convert", "s.ply", "s.laz")
    wpd("convert", "s.ply", "s.las")
    b = read("s.laz")
    vlr = laszip_vlr(b)
    compressor, chunk_size = struct.unpack_from("<H", vlr, 0)[0], struct.unpack_from("<I", vlr, 12)[0]
    items = [struct.unpack_from("<HHH", vlr, 34 + 6 * i) for i in range(vlr[32])]
    assert (compressor, chunk_size) == (3, 50000) and b[104] & 0x7F >= 6, (compressor, b[104])
    assert items[0] == (10, 30, 3) and all(i[2] == 3 for i in items), items
    off = struct.unpack_from("<I", b, 96)[0]
    table = struct.unpack_from("<q", b, off)[0]
    assert struct.unpack_from("<II", b, table) == (0, 3)
    check_same_as_las("s.laz", "s.las")
    wpd("convert", "s.laz", "back.ply")
    wpd("convert", "s.las", "ref.ply")
    assert read("back.ply") == read("ref.ply")


def test_laz_chunk_table_and_vlr():
    """Multi-chunk synthetic file (point format 3): 50,000-point chunks,
    the table where the i64 after the VLRs points, the VLR's items."""
    wpd("synth", "-n", 120001, "-o", "s.las")
    wpd("convert", "s.las", "s.laz")
    b = read("s.laz")
    off = struct.unpack_from("<I", b, 96)[0]
    assert b[104] == 0x80 | 3
    vlr = laszip_vlr(b)
    compressor, coder = struct.unpack_from("<HH", vlr, 0)
    chunk_size, nitems = struct.unpack_from("<I", vlr, 12)[0], struct.unpack_from("<H", vlr, 32)[0]
    items = [struct.unpack_from("<HHH", vlr, 34 + 6 * i) for i in range(nitems)]
    assert (compressor, coder, chunk_size) == (2, 0, 50000), (compressor, coder, chunk_size)
    assert items == [(6, 20, 2), (7, 8, 2), (8, 6, 2)], items
    table = struct.unpack_from("<q", b, off)[0]
    version, nchunks = struct.unpack_from("<II", b, table)
    assert (version, nchunks) == (0, 3) and off + 8 < table < len(b), (version, nchunks, table)
    out = wpd("info", "s.laz").stdout
    assert "chunks:           50000 points each, 3 in the chunk table" in out, out
    check_same_as_las("s.laz", "s.las")
    las_size, laz_size = os.path.getsize("s.las"), len(b)
    assert laz_size * 3 < las_size, (laz_size, las_size)


def test_laz_extra_bytes_item():
    src = data("las", "pdal_extrabytes.las")
    wpd("convert", src, "x.laz")
    wpd("convert", src, "x.las")
    vlr = laszip_vlr(read("x.laz"))
    items = [struct.unpack_from("<HHH", vlr, 34 + 6 * i) for i in range(vlr[32])]
    assert items[-1][0] == 0 and items[-1][1] == struct.unpack_from("<H", read("x.las"), 105)[0] - 34, items
    check_same_as_las("x.laz", "x.las")


def test_laz_empty_output():
    src = data("las", "pdal_no-points.las")
    wpd("convert", src, "e.laz")
    wpd("convert", src, "e.las")
    assert records("e.las")[0] == 0
    check_same_as_las("e.laz", "e.las")


@pytest.mark.parametrize("folder,name", [("las", "pdal_autzen_trim.las"),
                                         slow("laz", "lastools_fusa.laz"),
                                         slow("laz", "copcvalidator_ellipsoid-1.4.laz")])
def test_laz_resample_same_records_as_las_output(folder, name):
    """resample -o .laz against -o .las, in memory and through the tiled
    engine, from LAS and from LAZ input."""
    src = data(folder, name)
    for extra in ((), ("--min-tiles", 4)):
        opts = ("-n", 20000, "--threads", 2, "--force", *extra)
        wpd("resample", src, "-o", "r.las", *opts)
        wpd("resample", src, "-o", "r.laz", *opts)
        check_same_as_las("r.laz", "r.las")


def test_laz_resample_per_input():
    """--per-input keeps each input's name: LAZ inputs give LAZ outputs
    (one of them empty: all samples fall in the other), each matching the
    LAS the same run writes from the LAS twins."""
    os.mkdir("in_laz")
    os.mkdir("in_las")
    os.mkdir("out_laz")
    os.mkdir("out_las")
    wpd("synth", "-n", 60000, "-o", "a.las")
    shutil.copy(data("las", "pdal_no-points.las"), "b.las")
    for name in ("a", "b"):
        wpd("convert", name + ".las", "in_laz/%s.laz" % name)
        shutil.copy(name + ".las", "in_las/%s.las" % name)
    opts = ("-n", 20000, "--threads", 2)
    wpd("resample", "in_laz/a.laz", "in_laz/b.laz", "--per-input", "out_laz", *opts)
    wpd("resample", "in_las/a.las", "in_las/b.las", "--per-input", "out_las", *opts)
    # beside them the folder's collection state (docs/ingest.md)
    assert sorted(os.listdir("out_laz")) == [".wpd-collection", "a.laz", "b.laz"], \
        os.listdir("out_laz")
    for name in ("a", "b"):
        check_same_as_las("out_laz/%s.laz" % name, "out_las/%s.las" % name)
    assert records("out_las/a.las")[0] == 20000 and records("out_las/b.las")[0] == 0


def test_laz_refuses_waveform_formats_without_a_file():
    for name in ("laspy_simple1_3.las",):
        src = data("las", name)
        for cmd in (("convert", src, "no.laz"), ("resample", src, "-o", "no.laz", "-n", 100)):
            p = wpd(*cmd, check=False)
            lines = p.stderr.strip().splitlines()
            assert p.returncode != 0 and len(lines) == 1, (cmd, p.stderr)
            assert "cannot write LAZ point format" in lines[0] and "no.laz" in lines[0], lines
            assert os.listdir(".") == [], os.listdir(".")


def varied_las14(path, n, pdrf=8, extra=3, seed=7, channels=True):
    """A LAS 1.4 file of point format pdrf (6-8) whose records exercise the
    layered coder's contexts: scanner channels switching, up to 15
    returns, flags, classes, scan angles, sources, GPS times per channel
    that repeat, step and jump, RGB/NIR and extra bytes."""
    import random
    rnd = random.Random(seed)
    size = {6: 30, 7: 36, 8: 38}[pdrf] + extra
    t = [1e5, 2e5, 3.4e8, 5.0]
    recs = bytearray()
    for i in range(n):
        v = rnd.getrandbits(32)
        ch = (i // 300 + (v >> 3 if v % 7 == 0 else 0)) & 3 if channels else 1
        nret = 1 + v % 4 if v % 11 else (v >> 4) % 16
        ret = 1 + (v >> 3) % max(nret, 1) if v % 13 else (v >> 8) % 16
        if v % 4:
            t[ch] += 1e-5 if v % 7 else 2.5 * (v % 1000)
        rec = struct.pack("<iiiHBBBBhHd", i % 5000 * 37 + v % 100, i // 5000 * 50 - v % 7,
                          700 if v % 3 else 700 + v % 4000, 300 + (v >> 4) % 50 if v % 11 else (v >> 8) & 0xFFFF,
                          ret | nret << 4,
                          (0 if v % 19 else (v >> 5) & 15) | ch << 4 | ((v >> 9) & 1) << 6 | (0 if v % 23 else 128),
                          2 if v % 9 else 6 + (v >> 12) % 30, 0 if v % 17 else (v >> 20) & 255,
                          0 if v % 13 else (v >> 5) % 30000 - 15000, i // 20000 + (0 if v % 101 else 7), t[ch])
        if pdrf >= 7:
            g = (v + (v >> 16) % 300) & 0xFFFF if v % 3 else v & 0xFFFF
            b = (v >> 5) & 0xFFFF if v % 3 else v & 0xFFFF
            rec += struct.pack("<HHH", v & 0xFFFF, g, b)
        if pdrf == 8:
            rec += struct.pack("<H", (v >> 7) & 0xFFFF)
        rec += bytes((v >> (8 * k)) & 255 if i % 2 else k for k in range(extra))
        assert len(rec) == size
        recs += rec
    h = bytearray(375)
    h[0:4] = b"LASF"
    struct.pack_into("<H", h, 6, 16)
    h[24], h[25] = 1, 4
    struct.pack_into("<HHHIIBHI", h, 90, 1, 2024, 375, 375, 0, pdrf, size, 0)
    struct.pack_into("<ddd ddd", h, 131, 0.01, 0.01, 0.01, 0.0, 0.0, 0.0)
    struct.pack_into("<dddddd", h, 179, 2000.0, 0.0, 100.0, -100.0, 100.0, 0.0)
    struct.pack_into("<Q", h, 247, n)
    with open(path, "wb") as f:
        f.write(h + recs)


def test_laz_layered_scanner_channels_decode_with_laz_perf():
    """Records with odd return pairs and every change flag over 3 chunks:
    laz-perf decodes our layered LAZ to the LAS output's bytes, with
    scanner channels that switch (each channel its own POINT14 context,
    started from another's last point) and colour, NIR and extra bytes,
    whose items use the new channel's context on a point that switches
    channel and context 0 on the others, as LASzip's and laz-perf's do
    (docs/formats.md; LASzip itself: test_laz_laszip.py)."""
    for pdrf, extra, channels in ((6, 0, True), (7, 3, False), (7, 3, True), (8, 3, True)):
        varied_las14("v.las", 110000 if pdrf == 8 else 30000, pdrf, extra, channels=channels)
        wpd("convert", "v.las", "v.laz", "--force")
        wpd("convert", "v.las", "ref.las", "--force")
        check_same_as_las("v.laz", "ref.las")


def with_software(src, dst, software):
    """A copy of LAS/LAZ file src whose generating software (header bytes
    58-89) is software."""
    b = bytearray(read(src))
    b[58:90] = software.encode().ljust(32, b"\0")
    with open(dst, "wb") as f:
        f.write(b)


OLD_WPD = "written by an older wpd with a known LAZ scanner channel bug"


def old_wpd_warnings(path):
    """For each way of reading path (info, info --header-only, info --json:
    stderr and the file's "warnings", convert, resample), the lines that
    are the old-wpd warning; asserts that each run succeeds."""
    seen = {}
    for label, cmd in (("info", ("info", path)), ("header-only", ("info", "--header-only", path)),
                       ("json", ("info", "--json", path)),
                       ("convert", ("convert", path, "o.las", "--force")),
                       ("resample", ("resample", path, "-o", "r.las", "-n", 300, "--force"))):
        p = wpd(*cmd)
        seen[label] = [l for l in p.stderr.splitlines() if OLD_WPD in l]
        if label == "json":
            seen["json warnings"] = [w for w in json.loads(p.stdout)["files"][0]["warnings"]
                                     if OLD_WPD in w]
    return seen


def test_laz_old_wpd_file_with_channel_changes_warns():
    """wpd before 0.2.0 wrote layered LAZ whose colour, NIR and extra bytes
    took the point's scanner channel as their context: wrong where a
    chunk's points change channel. Its files say "wpd" as generating
    software and carry wpd's LASzip VLR; this wpd writes its version too.
    Every reader warns in one line on such a file whose first chunk
    changes channel (made here by setting a new file's software to "wpd"),
    and on nothing else: not on this wpd's files, not on old ones whose
    chunk keeps one channel or that have no item but POINT14."""
    varied_las14("v.las", 3000, pdrf=7, extra=3)  # channels change every 300 points
    wpd("convert", "v.las", "new.laz")
    software = read("new.laz")[58:90].rstrip(b"\0")
    assert software.startswith(b"wpd ") and len(software) > 4, software  # "wpd VERSION"
    wpd("convert", "v.las", "new.las")
    assert read("new.las")[58:90] == read("new.laz")[58:90]  # LAS says the same
    quiet = {k: [] for k in ("info", "header-only", "json", "json warnings", "convert",
                             "resample")}
    assert old_wpd_warnings("new.laz") == quiet
    with_software("new.laz", "old.laz", "wpd")
    seen = old_wpd_warnings("old.laz")
    for label, lines in seen.items():
        assert len(lines) == 1 and "re-create the file from its source" in lines[0], seen
        command = label if label in ("convert", "resample") else "info"
        assert lines[0].startswith("old.laz: " if label == "json warnings" else
                                   "wpd %s: warning: old.laz: " % command), (label, lines)
    # One channel a chunk, or POINT14 alone (format 6 without extra bytes):
    # old files read right, no warning.
    varied_las14("one.las", 3000, pdrf=8, extra=3, channels=False)
    varied_las14("six.las", 3000, pdrf=6, extra=0)
    for src in ("one.las", "six.las"):
        wpd("convert", src, "x.laz", "--force")
        with_software("x.laz", "old_x.laz", "wpd")
        assert old_wpd_warnings("old_x.laz") == quiet, src
