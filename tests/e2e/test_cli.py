"""End-to-end tests of what cron jobs rely on: exit codes, no partial
output and no spill files after errors and signals, --force,
--skip-existing, the output lock, the JSON report."""
import fcntl
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import time

import pytest

from formats import read_las
from harness import NC, REPO, WPD, data, slow, wpd

# The fast tier's clouds for the tests of cleanup, and the full scan.
CLOUDS = ["nc_cut", slow(NC)]


def leftovers(path="."):
    """Spill directories, temporary outputs and locks left in path."""
    return [f for f in os.listdir(path)
            if f.startswith("wpd-spill-") or ".wpd-tmp-" in f or f.endswith(".wpd-lock")]


def test_exit_codes_for_real_cases():
    src = data("las", "pdal_simple.las")
    assert wpd("resample", src, "-o", "ok.las", "-n", 100).returncode == 0
    assert wpd("resample", src, "-o", "x.las", check=False).returncode == 1       # no -n
    assert wpd("resample", src, "-o", "ok.las", "-n", 10, check=False).returncode == 1  # exists
    bad = data("bad", "pdal_1.2-with-color-clipped.las")
    assert wpd("resample", bad, "-o", "x.las", "-n", 10, check=False).returncode == 2
    assert wpd("resample", "missing.las", "-o", "x.las", "-n", 10, check=False).returncode == 3
    p = wpd("resample", data("scans", NC), "-o", "x.las", "-n", 100000, "--mem", "8M",
            check=False)
    assert p.returncode == 4
    assert sorted(os.listdir(".")) == ["ok.las"], os.listdir(".")


def limit_file_size():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))


@pytest.mark.parametrize("name", CLOUDS)
def test_disk_full_is_an_io_error_and_leaves_nothing(scan, name):
    src = scan(name)
    os.makedirs("spill")
    for extra in ([], ["--min-tiles", "4", "--tmpdir", "spill"]):
        p = subprocess.run([WPD, "resample", src, "-o", "out.las", "-n", "20000", *extra],
                           capture_output=True, text=True, preexec_fn=limit_file_size)
        assert p.returncode == 3, (extra, p.returncode, p.stderr)
        assert "disk full" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert not os.path.exists("out.las") and leftovers(".") == [] and leftovers("spill") == []


def start_stalled(args, point):
    env = dict(os.environ, WPD_TEST_STALL=point)
    p = subprocess.Popen([WPD, *map(str, args)], stderr=subprocess.PIPE, text=True, env=env)
    line = p.stderr.readline()
    assert "stalled at " + point in line, line
    return p


@pytest.mark.serial
@pytest.mark.parametrize("name", CLOUDS)
def test_signals_in_tile_and_write_phases_leave_nothing(scan, name):
    src = scan(name)
    os.makedirs("spill")
    args = ["resample", src, "-o", "out.las", "-n", 20000, "--min-tiles", 4, "--tmpdir", "spill"]
    for point in ("tile", "write"):
        for sig, code in ((signal.SIGTERM, -signal.SIGTERM), (signal.SIGINT, -signal.SIGINT)):
            p = start_stalled(args, point)
            assert leftovers(".") or leftovers("spill")  # there is something to clean up
            p.send_signal(sig)
            assert p.wait(timeout=30) == code
            assert not os.path.exists("out.las"), point
            assert leftovers(".") == [] and leftovers("spill") == [], (point, sig)


@pytest.mark.serial
@pytest.mark.parametrize("name", CLOUDS)
def test_sigkill_leftovers_are_removed_by_the_next_run(scan, name):
    src = scan(name)
    os.makedirs("spill")
    args = ["resample", src, "-o", "out.las", "-n", 20000, "--min-tiles", 4, "--tmpdir", "spill"]
    for point in ("tile", "write"):
        p = start_stalled(args, point)
        p.kill()
        p.wait(timeout=30)
        assert not os.path.exists("out.las")
        assert leftovers(".") or leftovers("spill"), point  # SIGKILL cannot clean up
        wpd(*args, "--force", "-q")  # the next run
        assert leftovers(".") == [] and leftovers("spill") == [], point
        assert read_las("out.las")["count"] == 20000
        os.remove("out.las")


def test_force_replaces_and_output_cannot_be_an_input():
    src = data("las", "pdal_simple.las")
    wpd("resample", src, "-o", "out.las", "-n", 100)
    p = wpd("resample", src, "-o", "out.las", "-n", 50, check=False)
    assert p.returncode == 1 and "--force" in p.stderr
    assert read_las("out.las")["count"] == 100
    wpd("resample", src, "-o", "out.las", "-n", 50, "--force")
    assert read_las("out.las")["count"] == 50
    p = wpd("resample", "out.las", "-o", "out.las", "-n", 10, "--force", check=False)
    assert p.returncode == 1 and "also an input" in p.stderr


def test_per_input_names_a_folder_that_exists():
    src = data("las", "pdal_simple.las")
    p = wpd("resample", src, "--per-input", "missing", "-n", 100, check=False)
    assert p.returncode == 1 and "missing: no such folder" in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and not os.path.exists("missing")
    with open("afile", "w") as f:
        f.write("x")
    p = wpd("resample", src, "--per-input", "afile", "-n", 100, check=False)
    assert p.returncode == 1 and "afile: not a folder" in p.stderr, p.stderr
    os.mkdir("thin")
    wpd("resample", src, "--per-input", "thin", "-n", 100)
    assert read_las(os.path.join("thin", os.path.basename(src)))["count"] == 100


def test_the_report_never_replaces_an_input_or_the_output():
    src = data("las", "pdal_simple.las")
    shutil.copy(src, "in.las")
    with open("in.las", "rb") as f:
        before = f.read()
    p = wpd("resample", "in.las", "-o", "out.las", "-n", 100, "--report", "in.las", check=False)
    assert p.returncode == 1 and "would replace an input" in p.stderr, p.stderr
    with open("in.las", "rb") as f:
        assert f.read() == before
    assert not os.path.exists("out.las") and leftovers(".") == []
    p = wpd("resample", "in.las", "-o", "out.las", "-n", 100, "--report", "out.las",
            check=False)
    assert p.returncode == 1 and "one file" in p.stderr, p.stderr
    assert not os.path.exists("out.las")
    # A report that exists is rewritten (a nightly job keeps one path).
    with open("run.json", "w") as f:
        f.write("old")
    wpd("resample", "in.las", "-o", "out.las", "-n", 100, "--report", "run.json")
    with open("run.json") as f:
        assert json.load(f)["output_points"] == 100


def test_the_report_never_replaces_a_per_input_output_or_the_collection_state():
    shutil.copy(data("las", "pdal_simple.las"), "in.las")
    os.mkdir("thin")

    def refused(inputs, report, says):
        before = sorted(os.listdir("thin"))
        p = wpd("resample", *inputs, "--per-input", "thin", "-n", "10%", "--report", report,
                check=False)
        assert p.returncode == 1 and says in p.stderr, (report, p.stderr)
        assert len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert sorted(os.listdir("thin")) == before, os.listdir("thin")

    # This night's output, however the path is written (through a link to
    # the folder too); the state.
    os.symlink("thin", "alias")
    refused(["in.las"], os.path.join("thin", "in.las"), "would replace the output of in.las")
    refused(["in.las"], "./thin/../thin/in.las", "would replace the output of in.las")
    refused(["in.las"], os.path.join("alias", "in.las"), "would replace the output of in.las")
    refused(["in.las"], os.path.join("thin", ".wpd-collection"), "the collection thin keeps")
    wpd("resample", "in.las", "--per-input", "thin", "-n", "10%", "--report", "run.json")
    with open("run.json") as f:
        assert json.load(f)["output_points"] > 0
    with open(os.path.join("thin", "in.las"), "rb") as f:
        night1 = f.read()
    # A later night, in.las no longer among the inputs: its output, the
    # state and the files beside it are still the collection's.
    shutil.copy(data("las", "pdal_simple.las"), "in2.las")
    for report in ("in.las", ".wpd-collection", ".wpd-collection.run", ".wpd-collection.new"):
        refused(["in2.las"], os.path.join("thin", report), "the collection thin keeps")
        refused(["in2.las"], os.path.join("alias", report), "the collection thin keeps")
    with open(os.path.join("thin", "in.las"), "rb") as f:
        assert f.read() == night1


def test_lock_keeps_two_runs_apart():
    src = data("las", "pdal_simple.las")
    with open(".out.las.wpd-lock", "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        p = wpd("resample", src, "-o", "out.las", "-n", 100, check=False)
        assert p.returncode == 3 and "another wpd run" in p.stderr, p.stderr
        assert not os.path.exists("out.las")
    wpd("resample", src, "-o", "out.las", "-n", 100)  # lock released: runs
    assert read_las("out.las")["count"] == 100 and leftovers(".") == []


def test_skip_existing_does_only_new_work():
    tiles = [data("scans", "lone-star_tile%d.las" % i) for i in range(1, 5)]
    os.makedirs("in")
    for t in tiles[:2]:
        os.symlink(t, os.path.join("in", os.path.basename(t)))
    os.makedirs("out")
    run = ["resample", "--per-input", "out", "-n", "5%", "--skip-existing", "-v"]
    wpd(*run, *sorted(os.path.join("in", f) for f in os.listdir("in")))
    # the outputs (beside them the collection's state, docs/ingest.md)
    first = {f: os.stat(os.path.join("out", f)).st_mtime_ns for f in os.listdir("out")
             if f != ".wpd-collection"}
    assert len(first) == 2
    p = wpd(*run, *sorted(os.path.join("in", f) for f in os.listdir("in")))
    assert "nothing to do" in p.stdout
    for t in tiles[2:]:  # the folder grows
        os.symlink(t, os.path.join("in", os.path.basename(t)))
    time.sleep(0.01)
    wpd(*run, *sorted(os.path.join("in", f) for f in os.listdir("in")))
    after = {f: os.stat(os.path.join("out", f)).st_mtime_ns for f in os.listdir("out")
             if f != ".wpd-collection"}
    assert len(after) == 4
    assert all(after[f] == first[f] for f in first), "old outputs were redone"


def documented_report_fields():
    with open(os.path.join(REPO, "docs", "report.md")) as f:
        return re.findall(r"^\| `(\w+)` \|", f.read(), re.M)


@pytest.mark.parametrize("name", CLOUDS)
def test_report_is_valid_json_with_the_documented_fields(scan, name):
    fields = documented_report_fields()
    assert len(fields) >= 20, fields
    for extra in ([], ["--min-tiles", 4]):
        wpd("resample", scan(name), "-o", "out.las", "-n", 20000, "--report", "r.json",
            "--metrics", "--force", "-q", *extra)
        with open("r.json") as f:
            r = json.load(f)
        assert set(fields) <= set(r), set(fields) - set(r)
        assert r["output_points"] == 20000 and r["metrics"]["resampled_points"] == 20000
        assert r["peak_rss_bytes"] > 0 and r["seconds"]["total"] > 0
        if extra:
            assert r["tiles"]["count"] >= 4 and r["spill"]["disk_bytes"] > 0
            assert len(r["tiles"]["boxes"]) == r["tiles"]["count"]
            # The exact count's files and the hints for smoothing, beside the spill.
            assert r["spill"]["work_file_bytes"] > 0
        else:
            assert r["spill"]["work_file_bytes"] == 0


def test_progress_only_when_asked():
    src = data("las", "pdal_autzen_trim.las")
    p = wpd("resample", src, "-o", "a.las", "-n", 1000)
    assert p.stderr == "" and p.stdout == ""  # not a terminal: silent
    p = wpd("resample", src, "-o", "b.las", "-n", 1000, "--verbose")
    assert "load" in p.stderr and "resampled" in p.stdout
    p = wpd("resample", src, "-o", "c.las", "-n", 1000, "--verbose", "--quiet")
    assert p.stderr == "" and p.stdout == ""


COMMANDS = ("resample", "info", "convert", "metrics", "preview", "synth", "edges")


def test_man_page_names_every_option_of_the_help_and_no_other():
    helped = set()
    for cmd in COMMANDS:
        p = wpd(cmd, "--help", check=False)
        helped |= set(re.findall(r"--[a-z][a-z-]*", p.stdout + p.stderr))
    with open(os.path.join(REPO, "docs", "wpd.1")) as f:
        man = set(re.findall(r"--[a-z][a-z-]*", f.read().replace("\\", "")))
    assert helped == man, ("only in --help", helped - man, "only in the man page", man - helped)


def test_removed_options_are_refused_in_one_line():
    src = data("las", "pdal_simple.las")
    for opt in (("--smooth-mode", "cotan"), ("--smooth-mode", "vertex-mean"),
                ("--free-surface",)):
        p = wpd("resample", src, "-o", "out.las", "-n", 100, *opt, check=False)
        lines = p.stderr.strip().splitlines()
        assert p.returncode == 1 and len(lines) == 1, (opt, p.returncode, p.stderr)
        assert lines[0].startswith("wpd resample: %s was removed" % opt[0]), lines
        assert not os.path.exists("out.las")
