"""End-to-end tests of the sharp-feature labels: the ground truth of `wpd synth
--edge-truth`, the detector measured against it (`wpd edges`), and the labels
of `wpd resample --sharp --edge-label` in LAS and PLY, read back with the
independent readers (formats.py)."""
import filecmp
import re
import struct

import numpy as np
import pytest

from formats import read_las, read_ply
from harness import NC, slow, wpd

# Standard record sizes of the LAS point data record formats 0..10.
PDRF_SIZE = [20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67]
# Extra Bytes data types 1..10 (LAS 1.4 R15 table 25).
EB_TYPES = ["u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f4", "f8"]


def extra_fields(h):
    """name -> (record offset, numpy type) of the extra bytes a LAS file's
    Extra Bytes VLR (LASF_Spec/4, 192-byte descriptors) describes."""
    vlr = [p for u, rid, p in h["vlrs"] if u == b"LASF_Spec" and rid == 4]
    assert len(vlr) == 1, "one Extra Bytes VLR"
    payload, out = vlr[0], {}
    assert len(payload) % 192 == 0
    pos = PDRF_SIZE[h["pdrf"]]
    for k in range(0, len(payload), 192):
        d = payload[k:k + 192]
        dtype, options = d[2], d[3]
        name = d[4:36].split(b"\0")[0].decode()
        if dtype == 0:          # undocumented bytes: options = their count
            pos += options
            continue
        assert 1 <= dtype <= 10, dtype
        out[name] = (pos, EB_TYPES[dtype - 1])
        pos += np.dtype(EB_TYPES[dtype - 1]).itemsize
    assert pos == h["record_length"], (pos, h["record_length"])
    return out


def las_field(h, name):
    off, t = extra_fields(h)[name]
    rec = np.frombuffer(h["points"], np.uint8).reshape(-1, h["record_length"])
    return rec[:, off:off + np.dtype(t).itemsize].copy().view("<" + t).ravel()


def test_synth_edge_truth_is_an_extra_field_and_changes_no_point():
    wpd("synth", "-n", 60000, "--seed", 5, "-o", "plain.las")
    wpd("synth", "-n", 60000, "--seed", 5, "-o", "truth.las", "--edge-truth")
    wpd("synth", "-n", 60000, "--seed", 5, "-o", "truth.ply", "--edge-truth")
    a, b = read_las("plain.las"), read_las("truth.las")
    assert (a["pdrf"], a["record_length"], b["pdrf"], b["record_length"]) == (3, 34, 3, 35)
    ra = np.frombuffer(a["points"], np.uint8).reshape(-1, 34)
    rb = np.frombuffer(b["points"], np.uint8).reshape(-1, 35)
    assert (ra == rb[:, :34]).all(), "the points are those of a run without the truth"
    truth = las_field(b, "edge_truth")
    assert set(np.unique(truth)) <= {0, 1, 2, 3, 4}
    assert 0 < (truth > 0).mean() < 0.05, (truth > 0).mean()
    cls = rb[:, 15] & 31
    assert not truth[(cls == 5) | (cls == 7)].any(), "vegetation or noise on a crease"
    hp, vp = read_ply("truth.ply")
    assert ("uchar", "edge_truth") in hp["props"]
    assert (vp["edge_truth"] == truth).all(), "PLY and LAS hold the same truth"


def measured(stdout, key):
    return float(re.search(key + r" ([0-9.]+)", stdout).group(1))


def labelled_against_truth(cloud, cap, out):
    """Runs `wpd edges` on cloud against its edge_truth and recomputes
    precision, recall and the recall per crease kind (1..4) from the fields
    of its output, checking them against what it printed."""
    said = wpd("edges", cloud, "--truth", "edge_truth", "--cap", cap, "-o", out).stdout
    h = read_las(out)
    truth, edge = las_field(h, "edge_truth"), las_field(h, "edge")
    assert set(np.unique(edge)) <= {0, 1}
    tp = int(((truth > 0) & (edge == 1)).sum())
    precision, recall = tp / edge.sum(), tp / (truth > 0).sum()
    assert abs(precision - measured(said, "precision")) < 1e-3, said
    assert abs(recall - measured(said, "recall")) < 1e-3, said
    kinds = {k: ((truth == k) & (edge == 1)).sum() / max((truth == k).sum(), 1)
             for k in (1, 2, 3, 4)}
    return precision, recall, kinds, edge, h


@pytest.mark.quality
def test_detector_precision_and_recall_on_synth():
    # The detector on every input point against the truth, cap 2.7 m (the
    # radius estimate of a run to 1 %, wider than the detector's reach of 4
    # spacings), in the default survey: ridges are found and what is
    # labelled is right; the walls carry no points or rows a metre apart,
    # so their creases are not found (docs/algorithm.md section 5: precision
    # 0.903, recall 0.107, ridges 0.979 on this cloud).
    wpd("synth", "-n", 300000, "--seed", 3, "-o", "city.las", "--edge-truth")
    precision, recall, kinds, edge, _ = labelled_against_truth("city.las", 2.7, "labelled.las")
    assert precision >= 0.9, precision
    assert kinds[1] >= 0.85, kinds
    assert 0.07 <= recall < 0.2, recall
    assert (edge == 1).mean() < 0.01, "labels are rare: creases only"


@pytest.mark.quality
def test_oblique_survey_shows_the_walls_and_their_creases():
    # synth --oblique: the same scene scanned from cross strips whose
    # pulses lean 35-65 degrees from nadir. Its walls carry points, so the
    # detector finds the creases of walls too (docs/algorithm.md section 5:
    # precision 0.862, recall 0.842, wall tops 0.919, corners 0.643, feet
    # 0.773, ridges 0.953 on this cloud at cap 3.13, against recall 0.14 in
    # the default survey).
    wpd("synth", "-n", 300000, "--seed", 1, "-o", "oblique.las", "--edge-truth", "--oblique")
    wpd("synth", "-n", 300000, "--seed", 1, "-o", "default.las", "--edge-truth")
    h = read_las("oblique.las")
    rec = np.frombuffer(h["points"], np.uint8).reshape(-1, h["record_length"])
    assert h["count"] == 300000
    angle = rec[:, 16].view(np.int8)
    assert angle.min() <= -60 and angle.max() >= 60, (angle.min(), angle.max())
    assert (abs(angle.astype(int)) >= 35).all(), "no pulse within 35 degrees of nadir"
    sources = np.unique(rec[:, 18:20].copy().view("<u2"))
    assert len(sources) >= 8, sources          # strips in both directions
    truth = las_field(h, "edge_truth")
    cls = rec[:, 15] & 31
    assert (cls == 5).mean() > 0.05 and (cls == 7).any(), "vegetation and noise kept"
    assert not truth[(cls == 5) | (cls == 7)].any(), "vegetation or noise on a crease"
    precision, recall, kinds, _, _ = labelled_against_truth("oblique.las", 3.13, "o_edges.las")
    _, recall_default, kinds_default, _, _ = labelled_against_truth("default.las", 3.13,
                                                                    "d_edges.las")
    assert precision >= 0.84, precision
    assert recall >= 0.82, recall
    assert kinds[2] >= 0.9 and kinds[3] >= 0.6 and kinds[4] >= 0.75, kinds
    assert recall >= 5 * recall_default, (recall, recall_default)
    assert kinds[1] >= 0.93, kinds


def test_oblique_edge_label_memory_equals_tiles():
    wpd("synth", "-n", 150000, "--seed", 6, "-o", "city.las", "--edge-truth", "--oblique")
    opts = ("-n", 8000, "--sharp", "--edge-label", "--no-smooth", "-v")
    one = wpd("resample", "city.las", "-o", "one.las", *opts).stdout
    wpd("resample", "city.las", "-o", "tiled.las", "--min-tiles", 6, *opts)
    assert filecmp.cmp("one.las", "tiled.las", shallow=False)
    edge = las_field(read_las("one.las"), "edge")
    said = int(re.search(r"labelled, (\d+) output points", one).group(1))
    assert edge.sum() == said > 0, (edge.sum(), said)


def test_resample_edge_label_in_las_and_ply_memory_and_tiles():
    # The oblique survey: its walls carry points, so its creases are seen at
    # this cap (the default survey's few labels at 5 % were lone points).
    wpd("synth", "-n", 100000, "--seed", 2, "-o", "city.las", "--edge-truth", "--oblique")
    wpd("convert", "city.las", "city.ply")
    for ext in (".las", ".ply"):
        opts = ("-n", 5000, "--sharp", "--edge-label", "--no-smooth", "--force", "-v")
        one = wpd("resample", "city" + ext, "-o", "one" + ext, *opts).stdout
        wpd("resample", "city" + ext, "-o", "tiled" + ext, "--min-tiles", 4, *opts)
        assert filecmp.cmp("one" + ext, "tiled" + ext, shallow=False), ext
        if ext == ".las":
            h = read_las("one.las")
            edge, n = las_field(h, "edge"), h["count"]
            assert "edge_truth" in extra_fields(h)
        else:
            hp, v = read_ply("one.ply")
            assert hp["props"][-1] == ("uchar", "edge")
            edge, n = v["edge"], len(v)
        assert n == 5000 and set(np.unique(edge)) <= {0, 1}
        said = int(re.search(r"labelled, (\d+) output points", one).group(1))
        assert edge.sum() == said > 0, (ext, edge.sum(), said)


def test_edge_label_replaces_an_input_field_of_that_name():
    wpd("synth", "-n", 100000, "--seed", 4, "-o", "city.las")
    wpd("resample", "city.las", "-o", "a.las", "-n", 20000, "--sharp", "--edge-label", "-q")
    p = wpd("resample", "a.las", "-o", "b.las", "-n", 5000, "--sharp", "--edge-label")
    assert "has a field edge" in p.stderr, p.stderr
    h = read_las("b.las")
    assert list(extra_fields(h)) == ["edge"] and h["record_length"] == 35


def test_edge_label_after_undescribed_extra_bytes():
    # A LAS 1.2 file of point format 0 with 3 extra bytes and no Extra Bytes
    # VLR: the label's descriptor follows one for the 3 undocumented bytes.
    n, rl = 400, 23
    head = bytearray(227)
    head[0:4] = b"LASF"
    head[24:26] = bytes([1, 2])
    struct.pack_into("<HIIBHI", head, 94, 227, 227, 0, 0, rl, n)
    struct.pack_into("<3d3d", head, 131, 0.01, 0.01, 0.01, 0, 0, 0)
    g = np.arange(n)
    x, y = (g % 20) * 50, (g // 20) * 50
    z = np.where(x < 500, x, 1000 - x)          # a ridge along y
    struct.pack_into("<6d", head, 179, x.max() / 100, 0, y.max() / 100, 0, z.max() / 100, 0)
    rec = np.zeros((n, rl), np.uint8)
    rec[:, :12] = np.stack([x, y, z], 1).astype("<i4").view(np.uint8).reshape(n, 12)
    rec[:, 20:23] = np.array([7, 8, 9], np.uint8)
    with open("odd.las", "wb") as f:
        f.write(bytes(head) + rec.tobytes())
    wpd("resample", "odd.las", "-o", "out.las", "-n", 100, "--sharp", "--edge-label", "-q")
    h = read_las("out.las")
    assert h["record_length"] == 24 and list(extra_fields(h)) == ["edge"]
    out = np.frombuffer(h["points"], np.uint8).reshape(-1, 24)
    assert (out[:, 20:23] == [7, 8, 9]).all(), "the undescribed bytes kept"
    assert set(np.unique(out[:, 23])) <= {0, 1}


def test_edge_label_needs_sharp():
    wpd("synth", "-n", 5000, "-o", "c.las")
    p = wpd("resample", "c.las", "-o", "o.las", "-n", 100, "--edge-label", check=False)
    assert p.returncode == 1 and "--sharp" in p.stderr


@pytest.mark.parametrize("name,n", [("nc_cut", 10000), slow(NC, 100000)])
def test_nc_labels_under_a_tenth(scan, name, n):
    src = scan(name)
    out = wpd("resample", src, "-o", "nc.las", "-n", n, "--sharp", "--edge-label",
              "-v").stdout
    labelled = int(re.search(r"sharp features: (\d+) input points", out).group(1))
    assert 0 < labelled < 0.1 * read_las(src)["count"], labelled
