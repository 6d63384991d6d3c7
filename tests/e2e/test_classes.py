"""End-to-end tests of resampling by class (--drop-class, --keep-class,
--class-count, --class-field): records checked with the independent readers
of formats.py."""
import json
import os
from collections import Counter

import numpy as np

from formats import las_xyz_int, read_las, read_ply
from harness import data, wpd

def records(path):
    """The raw point records of a LAS file and their classes: formats 0-5
    keep the class in bits 0-4 of byte 15, formats 6-10 in all of byte 16."""
    h = read_las(path)
    rec = np.frombuffer(h["points"], np.uint8).reshape(-1, h["record_length"])
    return rec, rec[:, 15] & 31 if h["pdrf"] <= 5 else rec[:, 16]


def as_set(rec):
    return Counter(bytes(r) for r in rec)


def city(seed=2, n=150000):
    wpd("synth", "-n", n, "--seed", seed, "-o", "city.las")
    return "city.las"


def test_synth_carries_ground_building_vegetation_and_noise():
    _, cls = records(city())
    assert set(np.unique(cls)) == {2, 5, 6, 7}, np.unique(cls)


def test_keep_class_copies_every_building_record_byte_for_byte():
    src = city()
    wpd("resample", src, "-o", "out.las", "-n", 2000, "--keep-class", 6)
    rin, cin = records(src)
    rout, cout = records("out.las")
    assert as_set(rout[cout == 6]) == as_set(rin[cin == 6])
    assert (cout != 6).sum() == 2000


def test_drop_class_leaves_no_noise_and_exact_n():
    src = city()
    wpd("resample", src, "-o", "out.las", "-n", 3000, "--drop-class", "7")
    _, cout = records("out.las")
    assert (cout == 7).sum() == 0
    assert len(cout) == 3000


def test_class_count_is_the_run_with_every_other_class_dropped():
    src = city()
    wpd("resample", src, "-o", "a.las", "-n", 1000, "--class-count", "2=1500",
        "--drop-class", 7, "--report", "a.json")
    wpd("resample", src, "-o", "b.las", "-n", 1500, "--drop-class", "0-1,3-255")
    ra, ca = records("a.las")
    rb, cb = records("b.las")
    assert (ca == 2).sum() == 1500 and len(rb) == 1500 and (cb == 2).all()
    assert as_set(ra[ca == 2]) == as_set(rb), "ground samples differ from the ground-only run"
    assert ((ca != 2) & (ca != 7)).sum() == 1000 and (ca == 7).sum() == 0
    rep = json.load(open("a.json"))
    lines = {l["class"]: l for l in rep["classes"]}
    assert lines[2]["role"] == "count" and lines[2]["output_points"] == 1500
    assert lines[7]["role"] == "drop" and lines[7]["output_points"] == 0
    assert lines[5]["role"] == "rest" and lines[6]["role"] == "rest"
    assert lines[5]["output_points"] + lines[6]["output_points"] == 1000
    assert rep["output_points"] == 2500


def test_classes_same_bytes_in_memory_in_tiles_and_on_any_threads():
    src = city(seed=4)
    args = ["-n", 1000, "--class-count", "2=1500", "--keep-class", 6, "--drop-class", 7,
            "--no-smooth"]
    wpd("resample", src, "-o", "mem2.las", *args, "--threads", 2)
    wpd("resample", src, "-o", "mem1.las", *args, "--threads", 1)
    wpd("resample", src, "-o", "tiles.las", *args, "--min-tiles", 16, "--threads", 2,
        "--report", "t.json")
    assert json.load(open("t.json"))["tiles"]["count"] >= 16
    a = open("mem2.las", "rb").read()
    assert a == open("mem1.las", "rb").read(), "1 vs 2 threads"
    assert a == open("tiles.las", "rb").read(), "in memory vs 16 tiles"


def test_autzen_ground_and_the_rest_get_their_own_counts():
    src = data("las", "pdal_autzen_trim.las")
    rin, cin = records(src)
    assert set(np.unique(cin)) == {1, 2}
    wpd("resample", src, "-o", "out.las", "-n", 3000, "--class-count", "2=5000",
        "--keep-class", 18)
    rout, cout = records("out.las")
    assert (cout == 2).sum() == 5000 and (cout == 1).sum() == 3000
    # every output record is an input record apart from the smoothed coordinates
    tails = Counter(bytes(r[12:]) for r in rin)
    assert all(tails[bytes(r[12:])] > 0 for r in rout)


def test_las_1_4_point_format_7_reads_its_full_class_byte():
    src = data("las", "pdal_autzen_trim_7.las")
    _, cin = records(src)
    assert set(np.unique(cin)) == {1, 2}
    wpd("resample", src, "-o", "out.las", "-n", 2000, "--class-count", "2=4000", "--no-smooth")
    _, cout = records("out.las")
    assert (cout == 2).sum() == 4000 and (cout == 1).sum() == 2000
    # the same points as the PDRF 3 twin: the same selection
    wpd("resample", data("las", "pdal_autzen_trim.las"), "-o", "twin.las", "-n", 2000,
        "--class-count", "2=4000", "--no-smooth")
    assert (las_xyz_int(read_las("out.las")) == las_xyz_int(read_las("twin.las"))).all()


def test_percentages_are_of_the_classes_not_named():
    src = city()
    _, cin = records(src)
    wpd("resample", src, "-o", "out.las", "-n", "10%", "--keep-class", 6, "--drop-class", 7)
    _, cout = records("out.las")
    rest = ((cin != 6) & (cin != 7)).sum()
    assert ((cout != 6) & (cout != 7)).sum() == round(rest / 10)


def test_bad_class_lists_are_one_line_usage_errors():
    src = city(n=20000)
    bad = [["--drop-class", "2,,3"], ["--drop-class", "a"], ["--keep-class", "5-2"],
           ["--drop-class", "70000"], ["--class-count", "2"], ["--class-count", "2=0"],
           ["--class-count", "2=x"], ["--class-count", "x=5"], ["--drop-class", "-3"],
           ["--drop-class", "2", "--keep-class", "1-3"],
           ["--class-count", "2=10", "--class-count", "2=20"],
           ["--class-count", "6=10", "--keep-class", "6"]]
    for opts in bad:
        p = wpd("resample", src, "-o", "out.las", "-n", 1000, *opts, check=False)
        assert p.returncode == 1, (opts, p.returncode, p.stderr)
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and "class" in lines[0], (opts, p.stderr)
        assert not os.path.exists("out.las")


def test_absent_classes_get_a_notice_and_the_run_goes_on():
    src = city()
    p = wpd("resample", src, "-o", "out.las", "-n", 1000, "--drop-class", "7,18")
    assert "no point of class 18" in p.stderr and "no point of class 7" not in p.stderr
    assert len(records("out.las")[1]) == 1000


def test_a_count_above_a_class_keeps_it_whole_with_a_notice():
    src = city()
    rin, cin = records(src)
    p = wpd("resample", src, "-o", "out.las", "-n", 1000, "--class-count", "7=1M")
    assert "keeping them all" in p.stderr
    rout, cout = records("out.las")
    assert as_set(rout[cout == 7]) == as_set(rin[cin == 7])
    assert len(cout) == 1000 + (cin == 7).sum()


def write_labelled_ply(path, n=30000, seed=1):
    """A plane of two halves labelled 3 and 9 (uchar property 'label')."""
    rng = np.random.default_rng(seed)
    v = np.zeros(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("label", "u1")])
    v["x"], v["y"] = rng.random(n) * 100, rng.random(n) * 100
    v["z"] = 0.01 * v["x"]
    v["label"] = np.where(v["x"] < 50, 3, 9)
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nproperty uchar label\nend_header\n" % n)
    with open(path, "wb") as f:
        f.write(head.encode() + v.tobytes())
    return v


def test_ply_class_field_names_the_property():
    v = write_labelled_ply("in.ply")
    wpd("resample", "in.ply", "-o", "out.ply", "-n", 500, "--class-field", "label",
        "--class-count", "9=700", "--drop-class", 4)
    _, out = read_ply("out.ply")
    assert (out["label"] == 9).sum() == 700 and (out["label"] == 3).sum() == 500
    p = wpd("resample", "in.ply", "-o", "bad.ply", "-n", 500, "--keep-class", 3, check=False)
    assert p.returncode == 1 and "classification" in p.stderr and "--class-field" in p.stderr
    assert not os.path.exists("bad.ply")
    p = wpd("resample", "in.ply", "-o", "bad.ply", "-n", 500, "--keep-class", 3,
            "--class-field", "x", check=False)
    assert p.returncode == 1 and "not an integer field" in p.stderr
    assert (v["label"] == 3).sum() > 500


def test_per_input_with_classes_splits_exact_totals():
    wpd("synth", "-n", 30000, "--seed", 1, "-o", "a.las")
    wpd("synth", "-n", 30000, "--seed", 2, "-o", "b.las")
    os.mkdir("out")
    wpd("resample", "a.las", "b.las", "--per-input", "out", "-n", 1500, "--keep-class", 6,
        "--drop-class", 7)
    total_keep = sum((records(f)[1] == 6).sum() for f in ("a.las", "b.las"))
    outs = [records(os.path.join("out", f))[1] for f in ("a.las", "b.las")]
    assert sum((c == 6).sum() for c in outs) == total_keep
    assert sum(((c != 6) & (c != 7)).sum() for c in outs) == 1500
    assert all((c != 7).all() for c in outs)


def test_a_value_that_is_no_class_is_a_one_line_input_error():
    n = 5000
    v = np.zeros(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("label", "<i4")])
    v["x"], v["y"] = np.arange(n) % 71, np.arange(n) // 71
    v["label"] = 1
    v["label"][4321] = 70000
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nproperty int label\nend_header\n" % n)
    with open("in.ply", "wb") as f:
        f.write(head.encode() + v.tobytes())
    before = open("in.ply", "rb").read()
    p = wpd("resample", "in.ply", "-o", "out.ply", "-n", 100, "--class-field", "label",
            "--drop-class", 5, "--tmpdir", ".", check=False)
    assert p.returncode == 2, (p.returncode, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "in.ply" in lines[0] and "70000" in lines[0], p.stderr
    assert sorted(os.listdir(".")) == ["in.ply"], os.listdir(".")
    assert open("in.ply", "rb").read() == before
