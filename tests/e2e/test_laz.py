"""LAZ input (issue 13: point formats 0-5, point-wise compressor; 6-10,
layered compressor, COPC included): `wpd info`, `wpd convert` and
`wpd resample` on LAZ files against their decompressed twins in
../shared/data/laz; COPC's own VLR and EVLR are dropped from every output;
damaged LAZ files fail with one line and exit 2."""
import json
import os
import struct

from harness import data, wpd


def records(path):
    """(count, point record bytes) of an uncompressed LAS file."""
    with open(path, "rb") as f:
        b = f.read()
    off = struct.unpack_from("<I", b, 96)[0]
    reclen = struct.unpack_from("<H", b, 105)[0]
    n = struct.unpack_from("<I", b, 107)[0]
    if b[25] >= 4:
        n = struct.unpack_from("<Q", b, 247)[0] or n
    return n, b[off:off + n * reclen]


def test_laz_convert_gives_the_twin_records():
    for name in ("lastools_house", "pdal_autzen_trim", "laspy_extra", "rlas_extra_byte",
                 "rlas_las14_prf6", "laspy_1_4_w_evlr", "copcvalidator_ellipsoid-1.4",
                 "laspy_append-bug", "untwine_eb", "laspy_simple_with_page.copc"):
        wpd("convert", data("laz", name + ".laz"), name + ".las")
        got, want = records(name + ".las"), records(data("laz", name + ".las"))
        assert got == want, (name, got[0], want[0])
        # what was written is plain LAS: no compression bits, no LASzip VLR
        with open(name + ".las", "rb") as f:
            head = f.read(4096)
        assert head[104] < 64 and b"laszip encoded" not in head, name


def test_laz_info_shows_compressor_chunks_items():
    path = data("laz", "lastools_fusa.laz")
    out = wpd("info", path).stdout
    assert "format:           LAZ 1.1, point format 1" in out, out
    assert "compressor:       point-wise chunked (2), LASzip 2.0r1" in out, out
    assert "chunks:           50000 points each, 6 in the chunk table" in out, out
    assert "POINT10 (20 bytes, v2) + GPSTIME11 (8 bytes, v2)" in out, out
    got = json.loads(wpd("info", "--json", path).stdout)["files"][0]
    assert got["format"] == "LAZ" and got["point_count"] == 277573, got
    laz = got["laz"]
    assert laz["compressor"] == 2 and laz["chunk_size"] == 50000 and laz["chunks"] == 6, laz
    assert [i["type"] for i in laz["items"]] == ["POINT10", "GPSTIME11"], laz


def test_laz_resample_same_bytes_as_las_twin():
    """In memory and through the tiled engine (which reads point ranges in
    parallel, seeking through the chunk table), on 1 and 2 threads. The
    scan decodes every chunk once; the tile and records passes read the
    records back from the cache (all 277 573 twice), and the cache is gone
    when the run ends."""
    laz, las = data("laz", "lastools_fusa.laz"), data("laz", "lastools_fusa.las")
    os.makedirs("tmp", exist_ok=True)
    for extra in ((), ("--min-tiles", 4)):
        for threads in (1, 2):
            opts = ("-n", 20000, "--no-smooth", "--threads", threads, "--tmpdir", "tmp", *extra)
            wpd("resample", laz, "-o", "from_laz.las", *opts, "--force", "--report", "r.json")
            wpd("resample", las, "-o", "from_las.las", *opts, "--force")
            with open("from_laz.las", "rb") as a, open("from_las.las", "rb") as b:
                assert a.read() == b.read(), (extra, threads)
            with open("r.json") as f:
                assert json.load(f)["records_cached"] == 2 * 277573, (extra, threads)
            assert os.listdir("tmp") == [], os.listdir("tmp")


def test_many_laz_inputs_share_one_cache_directory():
    """A run over more LAZ inputs than the temporary-directory registry has
    slots (64) and than a process may hold descriptors for comfortably:
    one cache directory for all, each file opened only to be read or
    written. Same bytes as from the LAS twins; nothing left in the tmpdir."""
    import shutil
    os.makedirs("tmp", exist_ok=True)
    lazs, lases = [], []
    for i in range(70):
        for src, dst in ((data("laz", "laspy_simple.laz"), lazs), (data("laz", "laspy_simple.las"), lases)):
            path = "in%02d%s" % (i, src[-4:])
            shutil.copyfile(src, path)
            dst.append(path)
    opts = ("-n", 30000, "--no-smooth", "--tmpdir", "tmp", "--force")
    wpd("resample", *lazs, "-o", "from_laz.las", *opts, "--report", "r.json")
    wpd("resample", *lases, "-o", "from_las.las", *opts)
    with open("from_laz.las", "rb") as a, open("from_las.las", "rb") as b:
        assert a.read() == b.read()
    with open("r.json") as f:
        assert json.load(f)["records_cached"] == 2 * 70 * 1065
    assert os.listdir("tmp") == [], os.listdir("tmp")


def test_laz_info_layered():
    out = wpd("info", data("laz", "laspy_append-bug.laz")).stdout
    assert "compressor:       layered chunked (3), LASzip 2.2r0" in out, out
    assert "POINT14 (30 bytes, v3) + RGBNIR14 (8 bytes, v3) + BYTE14 (3 bytes, v3)" in out, out
    out = wpd("info", data("laz", "laspy_simple_with_page.copc.laz")).stdout
    assert "variable size, 65 in the chunk table" in out, out
    assert "COPC" in out, out


def vlr_ids(path):
    """(user id, record id) of every VLR and EVLR of a LAS/LAZ file."""
    with open(path, "rb") as f:
        b = f.read()
    ids, at = [], struct.unpack_from("<H", b, 94)[0]
    for _ in range(struct.unpack_from("<I", b, 100)[0]):
        ids.append((b[at + 2:at + 18].rstrip(b"\0"), struct.unpack_from("<H", b, at + 18)[0]))
        at += 54 + struct.unpack_from("<H", b, at + 20)[0]
    if b[25] >= 4:
        at, n = struct.unpack_from("<QI", b, 235)
        for _ in range(n):
            ids.append((b[at + 2:at + 18].rstrip(b"\0"), struct.unpack_from("<H", b, at + 18)[0]))
            at += 60 + struct.unpack_from("<Q", b, at + 20)[0]
    return ids


def test_copc_vlr_and_evlr_dropped_from_every_output():
    for name in ("laspy_simple_with_page.copc", "rlas_example.copc"):
        src = data("laz", name + ".laz")
        assert (b"copc", 1) in vlr_ids(src) and (b"copc", 1000) in vlr_ids(src)
        for out in ("o.las", "o.laz", "o.ply"):
            wpd("convert", src, out, "--force")
            if out != "o.ply":
                assert not [i for i in vlr_ids(out) if i[0] == b"copc"], (name, out, vlr_ids(out))
            else:
                with open(out, "rb") as f:
                    assert b"copc" not in f.read(4096), name
        assert records("o.las") == records(data("laz", name + ".las")), name
        wpd("resample", src, "-o", "r.las", "-n", 500, "--force")
        assert not [i for i in vlr_ids("r.las") if i[0] == b"copc"], name


def test_laz_refusals_are_one_line():
    cases = (("rlas_fwf.laz", "waveform packets in LAZ are not supported"),
             ("pdal_simple-laszip-compressor-version-1.2r0.laz", "LASzip 1.x"))
    for name, expect in cases:
        path = data("laz", name)
        for cmd in (("info", path), ("convert", path, "out.las")):
            p = wpd(*cmd, check=False)
            lines = p.stderr.strip().splitlines()
            assert p.returncode == 2 and len(lines) == 1 and expect in lines[0], (cmd, p.stderr)
            assert path in lines[0], lines


def laz_with_items(path, pdrf, compressor, items, n=10):
    """A LAZ file of point format pdrf whose LASzip VLR lists items ((type,
    size, version), in record order) for compressor, n points of
    unreadable data: what wpd must refuse at open."""
    reclen = sum(size for _, size, _ in items)
    payload = struct.pack("<HHBBHIIqqH", compressor, 0, 3, 4, 3, 0, 50000, -1, -1, len(items))
    payload += b"".join(struct.pack("<HHH", *it) for it in items)
    vlr = bytearray(54)
    vlr[2:16] = b"laszip encoded"
    struct.pack_into("<HH", vlr, 18, 22204, len(payload))
    v14 = pdrf >= 6
    size = 375 if v14 else 235
    h = bytearray(size)
    h[0:4] = b"LASF"
    h[24], h[25] = 1, 4 if v14 else 3
    off = size + len(vlr) + len(payload)
    struct.pack_into("<HHHIIBHI", h, 90, 1, 2024, size, off, 1, pdrf | 0x80, reclen,
                     0 if v14 else n)
    struct.pack_into("<3d", h, 131, 0.01, 0.01, 0.01)
    if v14:
        struct.pack_into("<Q", h, 247, n)
    with open(path, "wb") as f:
        f.write(bytes(h) + bytes(vlr) + payload + struct.pack("<q", -1) + bytes(n * reclen))


def test_laz_waveform_items_refused_in_one_line():
    """Waveform packets in LAZ (WAVEPACKET13 in point formats 4 and 5,
    WAVEPACKET14 in 9 and 10) are refused at open in one line that says
    what to do, by every command (docs/formats.md says why): the shared
    data's one such file (format 4) and files made for formats 5, 9, 10."""
    p10, gps, rgb = (6, 20, 2), (7, 8, 2), (8, 6, 2)
    p14, nir = (10, 30, 3), (12, 8, 3)
    laz_with_items("w5.laz", 5, 2, [p10, gps, rgb, (9, 29, 1)])
    laz_with_items("w9.laz", 9, 3, [p14, (13, 29, 3)])
    laz_with_items("w10.laz", 10, 3, [p14, nir, (13, 29, 3), (14, 2, 3)])
    cases = ((data("laz", "rlas_fwf.laz"), "WAVEPACKET13"), ("w5.laz", "WAVEPACKET13"),
             ("w9.laz", "WAVEPACKET14"), ("w10.laz", "WAVEPACKET14"))
    for path, item in cases:
        for cmd in (("info", path), ("info", "--header-only", "--json", path),
                    ("convert", path, "out.las"), ("resample", path, "-o", "r.las", "-n", 5)):
            p = wpd(*cmd, check=False)
            lines = p.stderr.strip().splitlines()
            assert p.returncode == 2 and len(lines) == 1, (cmd, p.returncode, p.stderr)
            assert lines[0].startswith("wpd %s: %s: waveform packets in LAZ are not supported "
                                       "(item %s); decompress it first" % (cmd[0], path, item)), \
                lines
        assert not os.path.exists("out.las") and not os.path.exists("r.las")


def test_laz_damaged_exit_2():
    with open(data("laz", "lastools_house.laz"), "rb") as f:
        b = bytearray(f.read())
    off = struct.unpack_from("<I", b, 96)[0]
    with open("cut.laz", "wb") as f:
        f.write(b[:len(b) // 2])
    corrupt = bytearray(b)
    for i in range(off + 8 + 28 + 1000, off + 8 + 28 + 1100):
        corrupt[i] = (i * 37) & 255
    with open("corrupt.laz", "wb") as f:
        f.write(corrupt)
    # A layered chunk (point format 6) whose XY layer claims 0 bytes: its
    # decoder had no stream and divided by zero (a fuzz finding).
    with open(data("laz", "rlas_las14_prf6.laz"), "rb") as f:
        b = bytearray(f.read())
    off = struct.unpack_from("<I", b, 96)[0]
    reclen = struct.unpack_from("<H", b, 105)[0]
    xy_size = off + 8 + reclen + 4   # after the chunk's raw first point and its count
    assert struct.unpack_from("<I", b, xy_size)[0] > 0
    struct.pack_into("<I", b, xy_size, 0)
    with open("no_xy.laz", "wb") as f:
        f.write(b)
    for name in ("cut.laz", "corrupt.laz", "no_xy.laz"):
        for cmd in (("info", name), ("convert", name, "out.las", "--force")):
            p = wpd(*cmd, check=False)
            # cut.laz also warns that its chunk table is gone (read on sequentially)
            lines = [l for l in p.stderr.strip().splitlines() if ": warning: " not in l]
            assert p.returncode == 2 and len(lines) == 1 and "LAZ chunk" in lines[0], \
                (cmd, p.returncode, p.stderr)


def test_laz_unusable_chunk_table_reads_with_warning():
    with open(data("laz", "lastools_house.laz"), "rb") as f:
        b = bytearray(f.read())
    off = struct.unpack_from("<I", b, 96)[0]
    struct.pack_into("<q", b, off, len(b) + 1000)   # table offset past the end
    with open("notable.laz", "wb") as f:
        f.write(b)
    p = wpd("convert", "notable.laz", "out.las")
    assert "warning" in p.stderr and "chunk table is unusable" in p.stderr, p.stderr
    assert records("out.las") == records(data("laz", "lastools_house.las"))
