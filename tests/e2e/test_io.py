"""End-to-end tests of the readers and writers through `wpd info` and
`wpd convert` on the real files in ../shared/data."""
import json
import os
import re
import sys

import numpy as np

from formats import las_xyz_int, read_las, read_ply
from harness import REPO, Skip, data, manifest, wpd

BBOX = re.compile(r"bbox=\[([-\d.]+)\.\.([-\d.]+), ([-\d.]+)\.\.([-\d.]+), ([-\d.]+)\.\.([-\d.]+)\]")
NAN_NOTE = re.compile(r"(\d+) of (\d+) points have NaN")


def good_files():
    """(folder, manifest row) of every readable file in the manifests."""
    for folder in ("las", "ply", "scans"):
        for row in manifest(folder):
            yield folder, row


def info(path):
    return json.loads(wpd("info", "--json", path).stdout)["files"][0]


def test_info_matches_manifests():
    checked = 0
    for folder, row in good_files():
        path = data(folder, row["file"])
        got = info(path)
        expect = int(row["point_count"])
        assert got["point_count"] == expect, (path, got["point_count"], expect)
        nan = NAN_NOTE.search(row["notes"])
        finite = expect - int(nan.group(1)) if nan else expect
        assert got["finite_point_count"] == finite, (path, got["finite_point_count"], finite)
        box = BBOX.search(row["notes"])
        if got["format"] == "LAS" and box:
            want = [float(v) for v in box.groups()]
            hb = got["header_bounds"]
            have = [hb["min"][0], hb["max"][0], hb["min"][1], hb["max"][1], hb["min"][2],
                    hb["max"][2]]
            for a, b in zip(have, want):
                assert abs(a - b) <= 0.0005 + 1e-9 * abs(b), (path, have, want)
        checked += 1
    assert checked >= 60, checked


def test_info_text_and_help():
    out = wpd("info", data("las", "pdal_simple.las")).stdout
    assert "LAS 1.2, point format 3" in out and "1065" in out and "intensity" in out
    out = wpd("info", data("ply", "pcl_bun0_normals.ply")).stdout
    assert "binary_little_endian" in out and "normal_x" in out
    for cmd in ([], ["info"], ["convert"], ["synth"]):
        assert wpd(*cmd, "--help").stdout.startswith("usage:"), cmd
        assert re.match(r"wpd \d+\.\d+\.\d+", wpd(*cmd, "--version").stdout), cmd
    p = wpd("frobnicate", check=False)
    assert p.returncode == 1 and "unknown command" in p.stderr


def test_bad_files_fail_cleanly():
    for row in manifest("bad"):
        path = data("bad", row["file"])
        for args in (["info", path], ["convert", path, "out.las"], ["convert", path, "out.ply"]):
            p = wpd(*args, check=False)
            assert 0 < p.returncode < 128, (args, p.returncode)
            lines = p.stderr.strip().splitlines()
            assert len(lines) == 1 and row["file"] in lines[0], (args, p.stderr)
            assert os.listdir(".") == [], (args, os.listdir("."))


def test_missing_input_is_an_io_error():
    p = wpd("info", "no-such-file.las", check=False)
    assert p.returncode == 3 and "no-such-file.las" in p.stderr


def small_las_files(limit_bytes=5_000_000):
    for folder in ("las", "scans"):
        for row in manifest(folder):
            if row["file"].endswith(".las") and int(row["size_bytes"]) <= limit_bytes:
                yield data(folder, row["file"])


def test_las_to_las_keeps_records_and_vlrs():
    for path in small_las_files():
        wpd("convert", path, "out.las")
        a, b = read_las(path), read_las("out.las")
        assert a["count"] == b["count"] and a["pdrf"] == b["pdrf"], path
        assert a["version"] == b["version"] and a["record_length"] == b["record_length"], path
        assert a["points"] == b["points"], path + ": point records differ"
        assert a["vlrs"] == b["vlrs"], path + ": VLRs differ"
        if a["version"] >= (1, 4):
            assert a["evlrs"] == b["evlrs"], path + ": EVLRs differ"
        os.remove("out.las")


def test_las_header_recomputed():
    # laszip_5points_14 has a header min z below every point: the copy is tight.
    wpd("convert", data("las", "laszip_5points_14.las"), "out.las")
    h = read_las("out.las")
    z = las_xyz_int(h)[:, 2] * h["scale"][2] + h["offset"][2]
    assert abs(h["min"][2] - z.min()) < 1e-9 and abs(h["max"][2] - z.max()) < 1e-9


def ply_files():
    for folder in ("ply", "scans"):
        for row in manifest(folder):
            if row["file"].endswith(".ply"):
                yield data(folder, row["file"])


def finite_rows(arr):
    names = arr.dtype.names
    ok = np.ones(len(arr), bool)
    for k in ("x", "y", "z"):
        if k in names:
            ok &= np.isfinite(arr[k].astype(np.float64))
    return arr[ok]


def test_ply_to_ply_keeps_values():
    for path in ply_files():
        for ascii_flag in ([], ["--ascii"]):
            wpd("convert", *ascii_flag, path, "out.ply")
            ha, a = read_ply(path)
            hb, b = read_ply("out.ply")
            a = finite_rows(a)
            assert [p[1] for p in ha["props"]] == [p[1] for p in hb["props"]], path
            assert len(a) == len(b), (path, len(a), len(b))
            for name in a.dtype.names:
                assert np.array_equal(a[name], b[name]), (path, name)
            os.remove("out.ply")


def test_las_to_ply_to_las_round_trip():
    for name in ("pdal_autzen_trim.las", "pdal_autzen_trim_7.las", "pdal_extrabytes.las",
                 "laspy_append-bug_decompressed.las", "lazperf_rand1_6.las"):
        src = data("las", name)
        wpd("convert", src, "mid.ply")
        hp, p = read_ply("mid.ply")
        assert [t for t, n in hp["props"][:3]] == ["double"] * 3, name
        assert {"intensity", "classification", "return_number"} <= set(p.dtype.names), name
        wpd("convert", "mid.ply", "back.las")
        a, b = read_las(src), read_las("back.las")
        assert a["pdrf"] == b["pdrf"] and a["count"] == b["count"], name
        assert np.array_equal(las_xyz_int(a), las_xyz_int(b)), name + ": XYZ changed"
        std = {0: 20, 1: 28, 2: 26, 3: 34, 6: 30, 7: 36, 8: 38}[a["pdrf"]]
        ra = np.frombuffer(a["points"], np.uint8).reshape(-1, a["record_length"])[:, :std]
        rb = np.frombuffer(b["points"], np.uint8).reshape(-1, b["record_length"])[:, :std]
        assert np.array_equal(ra, rb), name + ": standard dimensions changed"
        for f in ("mid.ply", "back.las"):
            os.remove(f)


def test_ply_to_las_maps_colour_and_keeps_extras():
    src = data("ply", "meshlab_Laurana50k.ply")  # float xyz + uchar rgba
    wpd("convert", src, "out.las")
    h = read_las("out.las")
    assert h["pdrf"] == 7 and h["count"] == 27861
    _, v = read_ply(src)
    rec = np.frombuffer(h["points"], np.uint8).reshape(-1, h["record_length"])
    red = rec[:, 30:32].copy().view("<u2").ravel()
    assert np.array_equal(red, v["red"].astype(np.uint32) * 257)
    assert any(u == b"LASF_Spec" and i == 4 for u, i, _ in h["vlrs"])  # alpha as extra bytes
    xyz = las_xyz_int(h) * np.array(h["scale"]) + np.array(h["offset"])
    err = np.abs(xyz - np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64)).max()
    assert err <= max(h["scale"]) / 2 + 1e-12, err


def shared_pcio():
    """../shared/tools/pcio.py, the independent reader, as a module."""
    tools = os.path.join(REPO, "..", "shared", "tools")
    if not os.path.exists(os.path.join(tools, "pcio.py")):
        raise Skip("missing " + tools + "/pcio.py")
    if tools not in sys.path:
        sys.path.insert(0, tools)
    import pcio
    return pcio


def blender_247_ply(path, encoding):
    """A PLY as Blender 2.4x's exporter wrote it: a free-text line after the
    format line (issue 14), float32/uint8/int32 type names, a face list."""
    rng = np.random.default_rng(14)
    v = np.zeros(5, [(k, "f4") for k in ("x", "y", "z", "nx", "ny", "nz")])
    for k in v.dtype.names:
        v[k] = rng.uniform(-10, 10, 5).round(3)
    head = ("ply\nformat %s 1.0\n"
            "Created by Blender3D 247 - www.blender.org, source file: 'scene.blend'\n"
            "element vertex 5\n" % encoding
            + "".join("property float32 %s\n" % k for k in v.dtype.names)
            + "element face 1\nproperty list uint8 int32 vertex_indices\nend_header\n")
    with open(path, "wb") as f:
        f.write(head.encode())
        if encoding == "ascii":
            for row in v:
                f.write(("%s \n" % " ".join("%.6f" % x for x in row)).encode())
            f.write(b"3 0 1 2 \n")
        else:
            e = "<" if encoding == "binary_little_endian" else ">"
            f.write(v.astype(v.dtype.newbyteorder(e)).tobytes())
            f.write(np.array([3], "u1").tobytes() + np.array([0, 1, 2], e + "i4").tobytes())


def test_ply_blender_247_header_reads_with_one_warning():
    io = shared_pcio()
    for enc in ("ascii", "binary_little_endian", "binary_big_endian"):
        src = "blender_%s.ply" % enc
        blender_247_ply(src, enc)
        got = json.loads(wpd("info", "--json", src).stdout)["files"][0]
        assert len(got["warnings"]) == 1 and "PLY header line 3" in got["warnings"][0], got
        p = wpd("convert", src, "out.ply")
        warnings = [ln for ln in p.stderr.splitlines() if "warning" in ln]
        assert len(warnings) == 1, p.stderr
        assert src in warnings[0] and "is not a keyword line" in warnings[0], warnings
        # pcio keeps ascii values as decimals: the file says they are float32
        want = io.read_points(src).astype(np.float32).astype(np.float64)
        assert len(want) == 5 and np.array_equal(io.read_points("out.ply"), want), enc
        os.remove("out.ply")


def test_ply_odd_files_refused_with_one_line():
    base = ("ply\nformat ascii 1.0\n%selement vertex 2\nproperty float x\nproperty float y\n"
            "end_header\n%s")
    cases = [("proprety float z\n", "1 2\n3 4\n", "line 3: unknown keyword on a line shaped"),
             ("", "1 2 5\n3 4\n", "PLY line 7 holds more values"),
             ("", "1\n2\n3 4\n", "PLY line 7: element 'vertex' item 0 has fewer values"),
             ("1 2\n", "", "line 3: a number where a keyword belongs")]
    for i, (extra, body, want) in enumerate(cases):
        src = "odd_%d.ply" % i
        with open(src, "w") as f:
            f.write(base % (extra, body))
        for cmd in (["info"], ["convert", src.replace(".ply", ".las")]):
            p = wpd(cmd[0], src, *cmd[1:], check=False)
            lines = p.stderr.strip().splitlines()
            assert p.returncode == 2 and len(lines) == 1, (cmd, p.returncode, p.stderr)
            assert src in lines[0] and want in lines[0], lines
        assert not os.path.exists(src.replace(".ply", ".las"))


def test_refuses_to_overwrite_and_output_equal_input():
    src = data("las", "pdal_simple.las")
    wpd("convert", src, "out.las")
    p = wpd("convert", src, "out.las", check=False)
    assert p.returncode == 1 and "exists" in p.stderr
    wpd("convert", "--force", src, "out.las")
    p = wpd("convert", "--force", "out.las", "out.las", check=False)
    assert p.returncode == 1 and "also an input" in p.stderr
    assert read_las("out.las")["count"] == 1065


def test_several_inputs_are_one_cloud():
    tiles = [data("scans", "lone-star_tile%d.las" % i) for i in range(1, 5)]
    wpd("convert", *tiles, "all.las")
    h = read_las("all.las")
    assert h["count"] == 518862
    assert b"".join(read_las(t)["points"] for t in tiles) == h["points"]
