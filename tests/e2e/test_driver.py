"""End-to-end tests of the one resampling driver: a cloud held in memory
and the same cloud cut into tiles give the same samples (byte-identical
without smoothing, for both radius estimates, with and without --sharp (and
its labels, --edge-label), on every real scan), and with smoothing the same
quality."""
import filecmp
import json
import os

import pytest

from harness import DATA, Skip, data, wpd

SCANS = "scans"
ESTIMATES = ("multiscale", "paper")


def scans():
    d = os.path.join(DATA, SCANS)
    if not os.path.isdir(d):
        raise Skip("missing " + d)
    return sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith((".las", ".ply")))


def resample(src, out, n, *extra):
    os.makedirs("spill", exist_ok=True)
    wpd("resample", src, "-o", out, "-n", n, "-q", "--force", "--tmpdir", "spill",
        "--report", out + ".json", *extra)
    assert os.listdir("spill") == [], os.listdir("spill")
    with open(out + ".json") as f:
        return json.load(f)


def tiles_give_the_in_memory_bytes(src, cases):
    """Resamples src in memory and through 16 tiles for each (radius
    estimate, sharp options) case, without smoothing: the same bytes."""
    ext = os.path.splitext(src)[1]
    for estimate, sharp in cases:
        opts = ("--no-smooth", "--radius-estimate", estimate, *sharp)
        one = resample(src, "one" + ext, 5000, *opts)
        tiled = resample(src, "tiled" + ext, 5000, "--min-tiles", 16, *opts)
        assert one["tiles"]["count"] == 0 and tiled["tiles"]["count"] >= 16
        assert filecmp.cmp("one" + ext, "tiled" + ext, shallow=False), (src, opts)


def test_tiles_give_the_in_memory_bytes_on_small_clouds(nc_cut):
    """Both radius estimates on a cut of the airborne scan, and with --sharp
    and its labels on a range map (PLY)."""
    sharp = ("--sharp", "--edge-label")
    tiles_give_the_in_memory_bytes(nc_cut, [(e, ()) for e in ESTIMATES])
    tiles_give_the_in_memory_bytes(data(SCANS, "meshlab_rangemap_lato270.ply"),
                                   [(e, s) for e in ESTIMATES for s in ((), sharp)])


@pytest.mark.slow
def test_tiles_give_the_in_memory_bytes_on_every_scan():
    for src in scans():
        tiles_give_the_in_memory_bytes(src, [(e, s) for e in ESTIMATES
                                             for s in ((), ("--sharp", "--edge-label"))])


def metrics(orig, res):
    return json.loads(wpd("metrics", "--json", orig, res).stdout)


def smoothing_in_tiles_within_half_a_percent_of_memory(src, n, sharps):
    for sharp in sharps:
        resample(src, "one.las", n, *sharp)
        resample(src, "tiled.las", n, "--min-tiles", 16, *sharp)
        a, b = metrics(src, "one.las"), metrics(src, "tiled.las")
        for key in ("hausdorff", "mean_resampled_to_original", "mean_original_to_resampled"):
            assert abs(b[key] - a[key]) <= 0.005 * a[key], (sharp, key, a[key], b[key])
        for key in ("local_density", "voronoi_area"):
            assert abs(b[key]["cv"] - a[key]["cv"]) <= 0.005 * a[key]["cv"], (sharp, key,
                                                                             a[key], b[key])


@pytest.mark.quality
def test_smoothing_in_tiles_within_half_a_percent_of_memory_on_a_cut(nc_cut):
    smoothing_in_tiles_within_half_a_percent_of_memory(nc_cut, 20000, ((),))


@pytest.mark.slow
@pytest.mark.quality
def test_smoothing_in_tiles_within_half_a_percent_of_memory():
    smoothing_in_tiles_within_half_a_percent_of_memory(
        data(SCANS, "nc_raleigh_lidar_2269213.las"), 100000, ((), ("--sharp",)))


@pytest.mark.slow
def test_sharp_through_tiles_under_a_small_budget():
    # A cloud that does not fit --mem goes through the spill with --sharp
    # (it was refused before), with the exact count.
    wpd("synth", "-n", 400000, "--seed", 3, "-o", "city.las")
    rep = resample("city.las", "out.las", 4000, "--sharp", "--mem", "80M")
    assert rep["tiles"]["count"] >= 2 and rep["output_points"] == 4000, rep["tiles"]
