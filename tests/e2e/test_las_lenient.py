"""End-to-end tests of the LAS reader's leniency (docs/formats.md, "LAS:
lenient and strict") on hand-made files: a lenient file reads with one
warning line naming it and gives the points the independent reader
../shared/tools/pcio.py gives; a strict one fails with one line naming the
file and the field; LAS -> LAS keeps VLR and EVLR headers byte for byte."""
import json
import os
import struct
import sys

import numpy as np

from formats import read_ply
from harness import REPO, Skip, wpd

TOOLS = os.environ.get("WPD_TEST_TOOLS", os.path.join(REPO, "..", "shared", "tools"))


def pcio():
    """The independent reader/writer of ../shared/tools (skips without it)."""
    if not os.path.exists(os.path.join(TOOLS, "pcio.py")):
        raise Skip("missing " + TOOLS + "/pcio.py")
    if TOOLS not in sys.path:
        sys.path.insert(0, TOOLS)
    import pcio as module
    return module


def cloud(n=300, seed=7):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(500000, 500100, n), rng.uniform(4e6, 4e6 + 80, n),
                            rng.uniform(100, 130, n)])


def patch(path, offset, fmt, *values):
    with open(path, "r+b") as f:
        f.seek(offset)
        f.write(struct.pack(fmt, *values))


def warnings_of(p, path):
    """The warning lines of a finished wpd run; each must name path."""
    lines = [l for l in p.stderr.splitlines() if ": warning: " in l]
    for line in lines:
        assert path in line, line
    return lines


def test_waveform_pointer_past_the_end_reads_with_a_warning():
    """The issue's file: LAS 1.3, point format 4, waveform data kept in
    another file, start_of_waveform_data_packet_record past the end."""
    io = pcio()
    io.write_las("wave.las", cloud(), version=(1, 3), point_format=4, scale=0.001)
    size = os.path.getsize("wave.las")
    patch("wave.las", 6, "<H", 4)  # global encoding: waveform packets external
    patch("wave.las", 227, "<Q", size + 123456)
    before = open("wave.las", "rb").read()
    expect = io.read_points("wave.las")
    p = wpd("info", "--json", "wave.las")
    lines = warnings_of(p, "wave.las")
    assert len(lines) == 1 and "start_of_waveform_data_packet_record" in lines[0], p.stderr
    got = json.loads(p.stdout)["files"][0]
    assert got["point_count"] == len(expect) and got["evlrs"] == []
    assert got["warnings"] == [lines[0].split(": warning: ", 1)[1]]
    p = wpd("convert", "wave.las", "out.ply")
    assert len(warnings_of(p, "wave.las")) == 1
    _, v = read_ply("out.ply")
    assert np.array_equal(np.column_stack([v["x"], v["y"], v["z"]]), expect)
    p = wpd("convert", "wave.las", "out.las")
    assert np.array_equal(io.read_points("out.las"), expect)
    assert wpd("info", "out.las").stderr == ""  # the copy is clean
    assert open("wave.las", "rb").read() == before  # the input is never modified


def test_every_command_warns_once_per_file():
    io = pcio()
    io.write_las("a.las", cloud(400), scale=0.001)
    with open("a.las", "ab") as f:
        f.write(b"trailing junk")  # 13 bytes after the points
    expect = "a.las: 13 bytes after the 400 point records belong to no record; ignored"
    runs = {
        "info": ["info", "a.las"],
        "convert": ["convert", "a.las", "b.las"],
        "resample": ["resample", "a.las", "-o", "c.las", "-n", "100"],
        "metrics": ["metrics", "a.las", "b.las"],
        "preview": ["preview", "a.las", "-o", "a.png", "--width", "64", "--height", "64"],
    }
    for command, args in runs.items():
        p = wpd(*args)
        lines = warnings_of(p, "a.las")
        assert lines == ["wpd %s: warning: %s" % (command, expect)], (command, p.stderr)
    p = wpd("resample", "-q", "a.las", "-o", "d.las", "-n", "100")
    assert p.stderr == "", p.stderr  # --quiet prints nothing on success


def vlr_header(user, record_id, length, desc, extended=False):
    if extended:
        return struct.pack("<H16sHQ32s", 7, user, record_id, length, desc)
    return struct.pack("<H16sHH32s", 0xAABB, user, record_id, length, desc)


def test_vlr_and_evlr_header_bytes_survive_las_to_las():
    """Some vendors leave bytes after the NUL of a user id or description."""
    io = pcio()
    io.write_las("v.las", cloud(50), version=(1, 4), point_format=6, scale=0.001)
    raw = bytearray(open("v.las", "rb").read())
    hsize, off = struct.unpack_from("<HI", raw, 94)
    vh = vlr_header(b"Leica\0\x07\xff\x01junk", 1001, 4, b"Histogram\0\x1b[2J rest of it")
    evh = vlr_header(b"evlr\0\x80\x90tail", 9, 3, b"wkt\0\x00\x7fgarbage", extended=True)
    points = raw[off:]
    out = raw[:hsize] + vh + b"data" + points
    struct.pack_into("<II", out, 96, off + len(vh) + 4, 1)  # offset to points, VLR count
    struct.pack_into("<QI", out, 235, len(out), 1)  # EVLR start, count
    out += evh + b"abc"
    open("v.las", "wb").write(out)
    wpd("convert", "v.las", "w.las")
    copy = open("w.las", "rb").read()
    assert copy[hsize:hsize + len(vh)] == vh, "VLR header changed"
    start, count = struct.unpack_from("<QI", copy, 235)
    assert count == 1 and copy[start:start + 60] == evh, "EVLR header changed"
    assert copy[start + 60:] == b"abc"
    # wpd info shows the text with the bytes escaped, never raw.
    p = wpd("info", "v.las")
    assert "Leica" in p.stdout and "Histogram" in p.stdout and "evlr" in p.stdout
    assert not any(ord(c) < 32 and c != "\n" or ord(c) >= 127 for c in p.stdout)
    p = wpd("info", "--json", "v.las")
    got = json.loads(p.stdout)["files"][0]
    assert got["vlrs"][0]["user_id"] == "Leica" and got["evlrs"][0]["user_id"] == "evlr"


def test_evlr_start_inside_the_points_is_refused_in_one_line():
    io = pcio()
    io.write_las("s.las", cloud(40), version=(1, 4), point_format=6, scale=0.001)
    before = open("s.las", "rb").read()
    _, off = struct.unpack_from("<HI", before, 94)
    patch("s.las", 235, "<QI", off + 30 * 10, 1)
    for args in (["info", "s.las"], ["convert", "s.las", "t.las"]):
        p = wpd(*args, check=False)
        lines = p.stderr.strip().splitlines()
        assert p.returncode == 2 and len(lines) == 1, (args, p.stderr)
        assert "s.las" in lines[0] and "start_of_first_evlr" in lines[0], lines[0]
        assert sorted(os.listdir(".")) == ["s.las"], os.listdir(".")
