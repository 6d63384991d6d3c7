"""End-to-end tests of wpd-mpi (make MPI=1): `mpirun -np K wpd-mpi resample`
gives the plain binary's bytes for every K, and a rank that fails makes every
rank exit with the documented code, leaving no output and no spill."""
import filecmp
import json
import os
import shutil
import subprocess

import pytest

from harness import REPO, Skip, sanitized, slow, wpd

WPD_MPI = os.environ.get("WPD_MPI_BIN") or os.path.join(REPO, "wpd-mpi")


def launcher():
    """mpirun with the flags every test needs (root, more ranks than cores);
    skips the test without mpirun or wpd-mpi, and under the sanitizers."""
    path = shutil.which("mpirun")
    if not path or not os.path.exists(WPD_MPI):
        raise Skip("no mpirun or wpd-mpi (make MPI=1)")
    if sanitized():
        raise Skip("the sanitized run tests the plain binary")
    return [path, "--allow-run-as-root", "--oversubscribe"]


def mpirun(ranks, *args, rank1_prefix=None, rank1_args=(), check=True):
    """Runs wpd-mpi on `ranks` ranks. rank1_prefix: a shell command the
    second rank runs wpd-mpi under, rank1_args: arguments added to its
    command line (the other ranks run it plainly)."""
    base = launcher()
    # A test's chunk size (test_every_rank_writes_its_share...) reaches every rank.
    if "WPD_TEST_LAZ_CHUNK" in os.environ:
        base = base + ["-x", "WPD_TEST_LAZ_CHUNK"]
    argv = [WPD_MPI, *map(str, args)]
    if rank1_prefix is None and not rank1_args:
        cmd = base + ["-np", str(ranks)] + argv
    else:
        shell = (rank1_prefix or "") + " exec " + " ".join(argv + list(map(str, rank1_args)))
        cmd = base + ["-np", "1"] + argv + [":", "-np", "1", "sh", "-c", shell]
        if ranks > 2:
            cmd += [":", "-np", str(ranks - 2)] + argv
    # A hang (ranks waiting in exchanges that do not match) fails the test.
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError("%s -> %d: %s" % (" ".join(cmd), p.returncode, p.stderr.strip()))
    return p


def synth(path, n, seed):
    wpd("synth", "-n", n, "--seed", seed, "-o", path, "--force")


@pytest.mark.parametrize("points,rank_counts", [(30000, (1, 2, 3)),
                                                slow(300000, (1, 2, 3, 4))])
def test_every_rank_count_gives_the_plain_bytes(points, rank_counts):
    synth("in.las", points, 3)
    os.makedirs("spill")
    cases = [("in memory", ()), ("tiles", ("--min-tiles", 8)),
             ("tiles, no smoothing", ("--min-tiles", 8, "--no-smooth"))]
    for name, opts in cases:
        wpd("resample", "in.las", "-o", "plain.las", "-n", 5000, "-q", "--force", *opts)
        for ranks in rank_counts:
            mpirun(ranks, "resample", "in.las", "-o", "mpi.las", "-n", 5000, "-q", "--force",
                   "--tmpdir", "spill", *opts)
            assert filecmp.cmp("plain.las", "mpi.las", shallow=False), (name, ranks)
            assert os.listdir("spill") == [], (name, ranks, os.listdir("spill"))


def test_rounds_across_ranks_give_the_plain_bytes():
    """Chains of decisions past the halo: Poisson tiles re-run in further
    rounds with other ranks' decisions handed back, and the exact count's
    decisions take several rounds in a sweep, over several sweeps."""
    synth("in.las", 300000, 1)
    for n, ranks in ((20000, 2), (40000, 3)):
        check_rounds(n, ranks)


def check_rounds(n, ranks):
    import json
    opts = ("-n", n, "--min-tiles", 32, "-q", "--force")
    wpd("resample", "in.las", "-o", "plain.las", "--report", "plain.json", *opts)
    with open("plain.json") as f:
        plain = json.load(f)
    assert plain["resolution_rounds"] > 0, plain["resolution_rounds"]
    if n == 40000:
        assert plain["exact_rounds"] > plain["exact_sweeps"] > 1, plain
    mpirun(ranks, "resample", "in.las", "-o", "mpi.las", "--report", "mpi.json", *opts)
    assert filecmp.cmp("plain.las", "mpi.las", shallow=False), (n, ranks)
    with open("mpi.json") as f:
        mine = json.load(f)
    for key in ("resolution_rounds", "resolution_tiles", "exact_sweeps", "exact_rounds",
                "guarded_moves", "poisson_points"):
        assert mine[key] == plain[key], (n, ranks, key, mine[key], plain[key])
    # Each rank spilled its own tiles: together the plain run's spill.
    assert mine["spill"]["points"] == plain["spill"]["points"], (mine["spill"], plain["spill"])
    assert mine["ranks"] == ranks and mine["exchanged_bytes"] > 0, mine
    assert plain["ranks"] == 1 and plain["exchanged_bytes"] == 0 and plain["writers"] == 1


@pytest.mark.parametrize("rank_counts", [(2, 3), slow((2, 3, 4))])
def test_ply_and_per_input_outputs_give_the_plain_bytes(rank_counts):
    synth("a.las", 150000, 4)
    synth("b.las", 120000, 5)
    os.makedirs("plain")
    wpd("resample", "a.las", "-o", "plain.ply", "-n", 3000, "-q", "--min-tiles", 4)
    mpirun(3, "resample", "a.las", "-o", "mpi.ply", "-n", 3000, "-q", "--min-tiles", 4)
    assert filecmp.cmp("plain.ply", "mpi.ply", shallow=False)
    # --per-input: each rank writes the outputs of a run of whole files
    # (c.las, 40 points, gets a handful of the 4000).
    synth("c.las", 40, 6)
    synth("d.las", 90000, 7)
    names = ["a.las", "b.las", "c.las", "d.las"]
    wpd("resample", *names, "--per-input", "plain", "-n", 4000, "-q")
    for ranks in rank_counts:
        shutil.rmtree("mpi", ignore_errors=True)
        os.makedirs("mpi")
        mpirun(ranks, "resample", *names, "--per-input", "mpi", "-n", 4000, "-q",
               "--report", "r.json")
        # the outputs, and the folder's collection state (docs/ingest.md)
        assert sorted(os.listdir("plain")) == sorted(os.listdir("mpi")) == \
            sorted(names + [".wpd-collection"]), os.listdir("mpi")
        for f in names + [".wpd-collection"]:
            assert filecmp.cmp(os.path.join("plain", f), os.path.join("mpi", f),
                               shallow=False), (ranks, f)
        assert report_writers("r.json") == ranks


def test_one_summary_and_one_report_from_rank_0():
    synth("in.las", 100000, 6)
    p = mpirun(3, "resample", "in.las", "-o", "out.las", "-n", 2000, "-v", "--report", "r.json")
    assert p.stdout.count("resampled 100000 -> 2000 points") == 1, p.stdout
    assert os.path.exists("r.json") and os.path.exists("out.las")
    p = mpirun(2, "info", "in.las")
    assert p.stdout.count("format:") == 1, p.stdout


def nonfinite_ply(path, n):
    """A binary PLY of n points on a wavy sheet, one in 17 with a NaN x and
    one in 53 with an infinite z (dropped: global indices skip them)."""
    import math
    import struct
    with open(path, "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
                b"property double x\nproperty double y\nproperty double z\n"
                b"property ushort intensity\nend_header\n" % n)
        for i in range(n):
            x, y = (i * 0.6180339887) % 1 * 100, (i * 0.7548776662) % 1 * 100
            z = math.sin(x / 7) * 3 + (i % 10) * 0.01
            f.write(struct.pack("<dddH", math.nan if i % 17 == 5 else x, y,
                                math.inf if i % 53 == 7 else z, i % 65536))


def report_writers(path):
    with open(path) as f:
        return json.load(f)["writers"]


@pytest.mark.parametrize("points,n,chunk,smooth,rank_counts", [
    (30000, 13000, 5000, ("--no-smooth",), (3,)), slow(300000, 130000, None, (), (2, 3))])
def test_every_rank_writes_its_share_of_one_output(monkeypatch, points, n, chunk, smooth,
                                                   rank_counts):
    """Each rank reads the records of its share (whole LAZ chunks, rank 0's
    empty on 3 ranks at n = 2.6 chunks) and writes them: rank 0 into the
    output, the others through part files placed at their offsets; the
    bytes are the plain binary's for LAS, LAZ and ASCII PLY, and for an
    input whose non-finite points shift the global indices. (The fast
    tier's run takes LAZ chunks of 5 000 points and does not smooth: what
    is checked is the writing.)"""
    if chunk:
        monkeypatch.setenv("WPD_TEST_LAZ_CHUNK", str(chunk))
    synth("in.las", points, 12)
    nonfinite_ply("nan.ply", 2 * n)
    os.makedirs("spill")
    cases = [("in.las", "las", ()), ("in.las", "laz", ("--min-tiles", 4)),
             ("in.las", "ply", ("--ascii",)), ("nan.ply", "ply", ("--min-tiles", 3))]
    for src, ext, opts in cases:
        opts = (*opts, *smooth)
        wpd("resample", src, "-o", "plain." + ext, "-n", n, "-q", "--force",
            "--report", "plain.json", *opts)
        for ranks in rank_counts:
            mpirun(ranks, "resample", src, "-o", "mpi." + ext, "-n", n, "-q", "--force",
                   "--tmpdir", "spill", "--report", "r.json", *opts)
            assert filecmp.cmp("plain." + ext, "mpi." + ext, shallow=False), (src, ext, ranks)
            assert report_writers("r.json") == ranks, (src, ext, ranks)
            # No rank reads every point: the dropped ones are the ranks' sum.
            with open("plain.json") as f, open("r.json") as g:
                assert json.load(f)["dropped_non_finite"] == json.load(g)["dropped_non_finite"]
            assert os.listdir("spill") == [], os.listdir("spill")
    # Where the records cannot be read from a share (--metrics keeps every
    # output point on rank 0), rank 0 writes alone: the same bytes.
    mpirun(3, "resample", "in.las", "-o", "mpi.las", "-n", n, "-q", "--force",
           "--metrics", "--report", "r.json", *smooth)
    wpd("resample", "in.las", "-o", "plain.las", "-n", n, "-q", "--force", *smooth)
    assert filecmp.cmp("plain.las", "mpi.las", shallow=False)
    assert report_writers("r.json") == 1


def test_a_rank_that_cannot_write_its_part_fails_every_rank():
    """The second rank's part of the output passes its file size limit:
    every rank exits 3, no output, no part file, no temporary output."""
    synth("in.las", 200000, 13)
    os.makedirs("spill")
    p = mpirun(3, "resample", "in.las", "-o", "out.las", "-n", 100000, "--tmpdir", "spill",
               "--no-smooth", rank1_prefix="ulimit -f 500;", check=False)
    assert p.returncode == 3, (p.returncode, p.stderr)
    assert "wpd-part.las: write failed" in p.stderr, p.stderr
    assert os.listdir("spill") == [], os.listdir("spill")
    assert [f for f in os.listdir(".") if f.startswith("out") or ".out" in f] == [], \
        os.listdir(".")


def test_a_rank_that_cannot_write_its_per_input_outputs_fails_every_rank():
    """With --per-input the last rank's outputs pass its file size limit
    after the others finished theirs: every rank exits 3 and the folder
    holds no output and no temporary one."""
    synth("a.las", 120000, 14)  # more than half the samples: b.las is the second rank's
    synth("b.las", 80000, 15)
    os.makedirs("out")
    p = mpirun(2, "resample", "a.las", "b.las", "--per-input", "out", "-n", 60000,
               "--no-smooth", rank1_prefix="ulimit -f 500;", check=False)
    assert p.returncode == 3, (p.returncode, p.stderr)
    assert "write failed" in p.stderr, p.stderr
    assert os.listdir("out") == [], os.listdir("out")


def test_a_bad_input_fails_every_rank_with_code_2():
    synth("in.las", 50000, 7)
    with open("in.las", "rb") as f:
        blob = f.read()
    with open("cut.las", "wb") as f:
        f.write(blob[: len(blob) // 2])
    os.makedirs("spill")
    p = mpirun(3, "resample", "cut.las", "-o", "out.las", "-n", 1000, "--tmpdir", "spill",
               check=False)
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert "cut.las" in p.stderr
    assert not os.path.exists("out.las") and os.listdir("spill") == []
    assert sorted(os.listdir(".")) == ["cut.las", "in.las", "spill"], os.listdir(".")


def test_one_rank_out_of_disk_fails_every_rank_with_code_3():
    """The second rank's spill hits its file size limit (a full disk to it)
    while the others go on: every rank exits 3, no output, no spill."""
    synth("in.las", 300000, 8)
    os.makedirs("spill")
    p = mpirun(3, "resample", "in.las", "-o", "out.las", "-n", 3000, "--min-tiles", 8,
               "--tmpdir", "spill", rank1_prefix="ulimit -f 64;", check=False)
    assert p.returncode == 3, (p.returncode, p.stderr)
    assert not os.path.exists("out.las"), os.listdir(".")
    assert os.listdir("spill") == [], os.listdir("spill")
    assert [f for f in os.listdir(".") if f.startswith("out")] == []


@pytest.mark.serial
def test_one_rank_killed_ends_the_run_and_the_next_run_sweeps_its_files():
    """A rank killed outright (SIGKILL) cannot clean up: mpirun ends the
    others, no output appears, and the next run on the host removes what the
    dead ranks left in the tmpdir (their names carry this host and their
    pids)."""
    import signal
    import time
    synth("in.las", 300000, 9)
    os.makedirs("spill")
    base = launcher()
    argv = [WPD_MPI, "resample", "in.las", "-o", "out.las", "-n", "3000", "--min-tiles", "8",
            "--tmpdir", "spill", "-q"]
    stalled = "export WPD_TEST_STALL=tile; echo $$ > rank1.pid; exec " + " ".join(argv)
    cmd = base + ["-np", "1", *argv, ":", "-np", "1", "sh", "-c", stalled]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 60
        pid = None
        while time.time() < deadline and pid is None:
            time.sleep(0.2)
            if os.path.exists("rank1.pid"):
                with open("rank1.pid") as f:
                    text = f.read().strip()
                if text and any(("-%s-" % text) in d for d in os.listdir("spill")):
                    pid = int(text)
        assert pid is not None, os.listdir("spill")
        time.sleep(1)
        os.kill(pid, signal.SIGKILL)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode != 0, (p.returncode, err)
    assert not os.path.exists("out.las")
    assert any(("-%d-" % pid) in d for d in os.listdir("spill")), os.listdir("spill")
    wpd("resample", "in.las", "-o", "out.las", "-n", 3000, "--min-tiles", 8, "--tmpdir",
        "spill", "-q")
    assert os.listdir("spill") == [], os.listdir("spill")
    assert [f for f in os.listdir(".") if ".wpd-tmp-" in f] == []


def test_take_all_classes_and_laz_give_the_plain_bytes():
    """n above the input (every point kept, tile by tile, with labels), a run
    by class, and a LAZ input (each rank's scan caches only its share of the
    chunks) under several ranks."""
    synth("in.las", 60000, 10)
    wpd("convert", "in.las", "in.laz")
    cases = [("in.las", "-n", 70000, "--min-tiles", 8, "--sharp", "--edge-label"),
             ("in.las", "-n", 3000, "--min-tiles", 8, "--class-count", "6=500",
              "--keep-class", "2"),
             ("in.laz", "-n", 3000, "--min-tiles", 8)]
    for case in cases:
        wpd("resample", case[0], "-o", "plain.las", "-q", "--force", *case[1:])
        mpirun(3, "resample", case[0], "-o", "mpi.las", "-q", "--force", *case[1:])
        assert filecmp.cmp("plain.las", "mpi.las", shallow=False), case


def test_ranks_plan_with_the_smallest_budget():
    """Ranks given different budgets (each rank's default is its own
    machine's share) plan with the smallest: the plain run's bytes at that
    budget, here tiles (70M) where the larger budget (600M) holds the cloud
    in memory."""
    synth("in.las", 300000, 1)
    wpd("resample", "in.las", "-o", "plain.las", "-n", 3000, "--mem", "70M", "-q")
    args = ["resample", "in.las", "-o", "mpi.las", "-n", "3000", "-q", "--report", "r.json"]
    mpirun(2, *args, "--mem", "600M", rank1_args=("--mem", "70M"))
    assert filecmp.cmp("plain.las", "mpi.las", shallow=False)
    import json
    with open("r.json") as f:
        assert json.load(f)["tiles"]["count"] > 1


@pytest.mark.serial
def test_interrupting_mpirun_leaves_nothing():
    """Ctrl-C on mpirun while every rank is in the tile pass: mpirun ends the
    ranks with SIGTERM, each removes its spill, no output appears. Open MPI
    sends SIGKILL odls_base_sigkill_timeout seconds after SIGTERM (1 by
    default; with 0 the ranks leave their spill, as any SIGKILL does): on a
    machine loaded by the other tests a rank may not run within that second,
    so the test gives them 5 (mpirun then waits about twice that to end:
    30 would cost a minute; docs/scale-out.md)."""
    import signal
    import time
    synth("in.las", 300000, 11)
    os.makedirs("spill")
    base = launcher()
    env = dict(os.environ, WPD_TEST_STALL="tile")
    cmd = base + ["--mca", "odls_base_sigkill_timeout", "5", "-x", "WPD_TEST_STALL", "-np",
                  "2", WPD_MPI, "resample", "in.las", "-o", "out.las", "-n", "3000",
                  "--min-tiles", "8", "--tmpdir", "spill"]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.time() + 60
        while time.time() < deadline and len(os.listdir("spill")) < 2:
            time.sleep(0.2)
        assert len(os.listdir("spill")) >= 2, os.listdir("spill")
        time.sleep(1)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode != 0, (p.returncode, err)
    assert os.listdir("spill") == [], os.listdir("spill")
    assert sorted(os.listdir(".")) == ["in.las", "spill"], os.listdir(".")


@pytest.mark.parametrize("rank_counts", [(2,), slow((2, 4))])
def test_several_input_tiles_as_one_cloud_give_the_plain_bytes(rank_counts):
    """Tiles of a survey given as several files, one output, smoothed and
    not, on 2 ranks (and 4 in the full tier)."""
    for i in range(3):
        synth("t%d.las" % i, 80000, 20 + i)
    files = ["t0.las", "t1.las", "t2.las"]
    for opts in ((), ("--no-smooth",)):
        wpd("resample", *files, "-o", "plain.las", "-n", 4000, "--min-tiles", 6, "-q",
            "--force", *opts)
        for ranks in rank_counts:
            mpirun(ranks, "resample", *files, "-o", "mpi.las", "-n", 4000, "--min-tiles", 6,
                   "-q", "--force", *opts)
            assert filecmp.cmp("plain.las", "mpi.las", shallow=False), (opts, ranks)
