"""Fault injection for the commands other than resample, and the loose
ends of resample's own outputs.

`wpd convert`, `info --json`, `metrics`, `preview` and `synth` meet the
faults test_faults.py makes `wpd resample` meet: truncated inputs, inputs
that shrink or fail (EIO) while read, a full disk, data lost at fsync or
close, SIGTERM and SIGINT at random moments; and standard output that
cannot be written. Each must end with its documented exit code and one line
naming the file, leave nothing under an output's name, no temporary file
or lock, and the inputs unchanged. Then `resample --report` when the report
cannot be written, and close() failing on spill files. The interposer,
the full disk and the synthetic inputs are test_faults.py's."""
import os
import random
import signal
import subprocess
import time

import pytest

from harness import WPD
from test_faults import (PATHS, Case, FullDisk, check_one_line, cuts, leftovers, point_count,
                         preload, run, sha256, stop_at, synth, truncate_copy)


class Command:
    """One run of `wpd ARGS`: inputs hashed first, then checked after;
    outputs are the files that must not exist after a failure."""

    def __init__(self, args, inputs=(), outputs=()):
        self.args = [str(a) for a in args]
        self.name = self.args[0]
        self.inputs, self.outputs = list(inputs), list(outputs)
        self.before = {p: sha256(p) for p in self.inputs}

    def run(self, **kw):
        self.p = run(self.args, **kw)
        return self.p

    def check_no_temporaries_inputs_unchanged(self, what):
        left = leftovers(*{".", *(os.path.dirname(o) or "." for o in self.outputs)})
        assert left == [], "%s: left behind %s" % (what, left)
        for p, h in self.before.items():
            assert sha256(p) == h, "%s: input %s changed" % (what, p)

    def check_clean(self, what):
        for out in self.outputs:
            assert not os.path.exists(out), "%s: output %s left" % (what, out)
        self.check_no_temporaries_inputs_unchanged(what)

    def check_failed(self, what, code, names=None, says=()):
        msg = check_one_line(self.p, what, code, self.name, names, says)
        self.check_clean(what)
        return msg

    def check_complete(self, what):
        for out in self.outputs:
            assert os.path.getsize(out) > 0, what
            if out.endswith((".las", ".ply")):
                point_count(out)  # complete: the point block is all there
        self.check_no_temporaries_inputs_unchanged(what)

    def check_succeeded(self, what):
        assert self.p.returncode == 0, "%s: exit %d: %s" % (what, self.p.returncode,
                                                           self.p.stderr.strip())
        self.check_complete(what)

    def check_interrupted(self, what):
        """Killed by a signal: no output, or (the signal came after the
        renames, on the way out) every output, complete."""
        present = [o for o in self.outputs if os.path.exists(o)]
        if present:
            assert present == self.outputs, "%s: only %s of %s" % (what, present, self.outputs)
            self.check_complete(what)
            self.remove_outputs()
        else:
            self.check_clean(what)
        return bool(present)

    def remove_outputs(self):
        for out in self.outputs:
            if os.path.exists(out):
                os.remove(out)


def companion():
    """A small second cloud: metrics' other side, preview's other panel."""
    return synth(2_000, "las", seed=2)


def readers(src):
    """Every place a command reads src: (label, Command) pairs."""
    other = "out.ply" if src.endswith(".las") else "out.las"
    small = companion()
    return [
        ("convert", Command(["convert", src, other], [src], [other])),
        ("info --json", Command(["info", "--json", src], [src])),
        ("metrics ORIGINAL", Command(["metrics", src, small], [src, small])),
        ("metrics RESAMPLED", Command(["metrics", small, src], [src, small])),
        ("preview", Command(["preview", src, "-o", "out.png", "-q"], [src], ["out.png"])),
        ("preview AFTER", Command(["preview", small, src, "-o", "out.png", "-q"], [src, small],
                                  ["out.png"])),
    ]


def sources():
    return [synth(30_000, "las"), synth(30_000, "ply"), synth(10_000, "ply", ascii_ply=True)]


# ------------------------------------------------------------------ inputs

def test_commands_refuse_truncated_inputs():
    runs = 0
    for src in sources():
        ext = os.path.splitext(src)[1]
        for cut_name, size in cuts(src).items():
            bad = truncate_copy(src, "cut_%s%s" % (cut_name.replace(" ", "_"), ext), size)
            for label, cmd in readers(bad):
                what = "%s: %s cut at %d (%s)" % (label, os.path.basename(src), size, cut_name)
                cmd.run()
                cmd.check_failed(what, 2, names=bad)
                runs += 1
            os.remove(bad)
    assert runs == 36, runs


def bytes_read(cmd, src):
    """Bytes a clean run of cmd reads from src."""
    count_file = os.path.abspath("read-count")
    cmd.run(env=preload(READ_FILE=src, READ_COUNT=count_file))
    cmd.check_succeeded("clean run counting reads")
    cmd.remove_outputs()
    with open(count_file) as f:
        return int(f.read())


def test_commands_report_read_errors_and_inputs_that_shrink():
    """EIO in the header and in the points; the reads ending early (the
    file truncated by another program while it is read)."""
    for src in sources():
        for label, cmd in readers(src):
            total = bytes_read(cmd, src)
            name = "%s: %s" % (label, os.path.basename(src))
            for after in (100, total // 2):
                cmd.run(env=preload(READ_FILE=src, READ_AFTER=after))
                cmd.check_failed("%s, EIO after %d of %d bytes" % (name, after, total), 3,
                                 names=src, says=("Input/output error",))
            cmd.run(env=preload(READ_FILE=src, READ_AFTER=total // 2, READ_EOF=1))
            cmd.check_failed("%s, ends after %d of %d bytes" % (name, total // 2, total), 2,
                             names=src)


# ------------------------------------------------------------------ outputs

def writers(src, folder):
    """Every command writing into folder: Commands (their outputs named)."""
    o = folder + "/"
    tiles = [o + "t_tile%d.las" % k for k in (1, 2, 3)]
    return [
        Command(["convert", src, o + "out.las"], [src], [o + "out.las"]),
        Command(["convert", src, o + "out.ply"], [src], [o + "out.ply"]),
        Command(["convert", "--ascii", src, o + "out.ply"], [src], [o + "out.ply"]),
        Command(["preview", src, "-o", o + "out.png", "-q"], [src], [o + "out.png"]),
        Command(["synth", "-n", 20_000, "-o", o + "s.las"], [], [o + "s.las"]),
        Command(["synth", "-n", 20_000, "-o", o + "s.ply"], [], [o + "s.ply"]),
        Command(["synth", "-n", 20_000, "--tiles", 3, "-o", o + "t.las"], [], tiles),
    ]


def test_commands_on_a_full_disk():
    src = synth(100_000, "las")
    full = FullDisk("full", 64 << 10)
    try:
        print("  full disk: " + full.means)
        for cmd in writers(src, "full"):
            cmd.run(env=full.env)
            cmd.check_failed(" ".join(cmd.args), 3, names="full/", says=("disk full",))
            if full.mounted:
                assert os.listdir("full") == [], os.listdir("full")
    finally:
        full.close()


def test_commands_errors_reported_only_by_fsync_or_close():
    src = synth(30_000, "las")
    os.makedirs("outdir")
    for fault, says in (({"SYNC_DIR": os.path.abspath("outdir")}, "Input/output error"),
                        ({"CLOSE_DIR": os.path.abspath("outdir")}, "disk full")):
        for cmd in writers(src, "outdir"):
            cmd.run(env=preload(**fault))
            cmd.check_failed("%s, %s" % (list(fault)[0], " ".join(cmd.args)), 3,
                             names="outdir/", says=(says,))


def test_a_failed_forced_run_keeps_the_files_it_would_replace():
    """--force: the new files replace the old ones together or not at all.
    The disk reports a loss at the close of the third file (synth's third
    tile, resample's third output): the first two must not have replaced
    theirs."""
    os.makedirs("outdir")
    first = run(["synth", "-n", 30_000, "--tiles", 3, "-o", "outdir/t.las"])
    assert first.returncode == 0, first.stderr
    old = {p: sha256(os.path.join("outdir", p)) for p in os.listdir("outdir")}
    assert len(old) == 3, old
    fault = preload(CLOSE_DIR=os.path.abspath("outdir"), CLOSE_AFTER=2)
    cmd = Command(["synth", "-n", 30_000, "--tiles", 3, "--seed", 2, "--force", "-o",
                   "outdir/t.las"])
    cmd.run(env=fault)
    check_one_line(cmd.p, "synth --tiles 3 --force", 3, "synth", names="outdir/t_tile3.las",
                   says=("disk full",))
    now = {p: sha256(os.path.join("outdir", p)) for p in os.listdir("outdir")}
    assert now == old, "a failed --force run changed %s" % sorted(
        p for p in set(now) | set(old) if now.get(p) != old.get(p))


def test_standard_output_that_cannot_be_written_is_an_io_error():
    """stdout on a full disk (/dev/full): info and metrics lose their
    product, the others their summary line. One line on stderr, exit 3; an
    output file written before the summary stays (it is complete)."""
    src = synth(30_000, "las")
    small = companion()
    cases = [(["info", "--json", src], None), (["info", src], None),
             (["metrics", src, small], None), (["convert", src, "out.ply"], "out.ply"),
             (["preview", src, "-o", "out.png"], "out.png"),
             (["synth", "-n", 1000, "-o", "s.las"], "s.las"),
             (["resample", src, "-o", "r.las", "-n", 500, "--verbose", "--report", "r.json"],
              "r.las")]
    with open("/dev/full", "w") as devfull:
        for args, out in cases:
            p = subprocess.run([WPD, *map(str, args)], stdout=devfull, stderr=subprocess.PIPE,
                               text=True, timeout=60)
            what = "wpd %s > /dev/full" % " ".join(map(str, args))
            if args[0] == "resample":  # --verbose: progress lines on stderr first
                p.stderr = p.stderr.strip().splitlines()[-1]
            check_one_line(p, what, 3, args[0], names="standard output",
                           says=("disk full",))
            if out:
                assert os.path.getsize(out) > 0, what
                os.remove(out)
            assert leftovers(".") == [], what
    assert sha256(src) == sha256(synth(30_000, "las"))


# ------------------------------------------------------------------ signals

@pytest.mark.serial
def test_commands_stopped_while_writing_leave_nothing():
    """Every command that writes files, stopped with its temporary outputs
    open (the "write" stop point): SIGTERM, SIGINT and SIGHUP end it by
    that signal with no output and no temporary file; after SIGKILL the
    next run of the command removes what it left and finishes. synth
    --tiles 20 keeps 20 temporary files open at once, more than the signal
    handlers' registry holds one by one."""
    src = synth(30_000, "las")
    tiles = ["t_tile%d.las" % k for k in range(1, 21)]
    cmds = [Command(["convert", src, "out.ply"], [src], ["out.ply"]),
            Command(["convert", src, "out.laz"], [src], ["out.laz"]),
            Command(["preview", src, "-o", "out.png", "-q"], [src], ["out.png"]),
            Command(["synth", "-n", 30_000, "-o", "s.las"], [], ["s.las"]),
            Command(["synth", "-n", 30_000, "--tiles", 20, "-o", "t.las"], [], tiles)]
    for cmd in cmds:
        for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGKILL):
            what = "%s, %s while writing" % (" ".join(cmd.args), sig.name)
            rc, err = stop_at(cmd.args, "write", sig)
            assert rc == -sig, "%s: exit %d: %s" % (what, rc, err)
            for out in cmd.outputs:
                assert not os.path.exists(out), "%s: output %s left" % (what, out)
            if sig != signal.SIGKILL:
                cmd.check_clean(what)
                continue
            cmd.run()
            cmd.check_succeeded("the run after " + what)
            cmd.remove_outputs()


@pytest.mark.slow
@pytest.mark.serial
def test_commands_stopped_by_signals_at_random_moments_leave_nothing():
    """SIGTERM and SIGINT at seeded random fractions of an uninterrupted
    run: killed by the signal with nothing left, or finished first with
    complete outputs (also when the signal lands after the renames, on the
    way out: slow under ASan, whose leak check runs at exit). synth
    --tiles 20 keeps 20 temporary files open at once, more than the signal
    handlers' registry holds one by one."""
    big, mid = synth(1_000_000, "las"), synth(100_000, "las")
    seed = int(os.environ.get("WPD_FAULT_SEED", random.randrange(1 << 30)))
    rng = random.Random(seed)
    print("  seed %d (WPD_FAULT_SEED reproduces)" % seed)
    tiles = ["t_tile%d.las" % k for k in range(1, 21)]
    cmds = [Command(["convert", big, "out.ply"], [big], ["out.ply"]),
            Command(["info", "--json", big], [big]),
            Command(["metrics", mid, companion()], [mid, companion()]),
            Command(["preview", mid, "-o", "out.png", "-q"], [mid], ["out.png"]),
            Command(["synth", "-n", 2_000_000, "-o", "s.las"], [], ["s.las"]),
            Command(["synth", "-n", 1_000_000, "--tiles", 20, "-o", "t.las"], [], tiles)]
    interrupted = 0
    for cmd in cmds:
        t = time.monotonic()
        cmd.run()
        base = time.monotonic() - t
        cmd.check_succeeded("uninterrupted " + " ".join(cmd.args))
        cmd.remove_outputs()
        for k in range(4):
            sig = (signal.SIGTERM, signal.SIGINT)[k % 2]
            delay = rng.uniform(0.05, 0.9) * base
            what = "%s, %s after %.3f of %.3f s" % (" ".join(cmd.args), sig.name, delay, base)
            p = subprocess.Popen([WPD, *cmd.args], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True)
            time.sleep(delay)
            p.send_signal(sig)
            _, err = p.communicate(timeout=60)
            cmd.p = subprocess.CompletedProcess(p.args, p.returncode, "", err)
            if p.returncode == 0:
                cmd.check_succeeded(what)
                cmd.remove_outputs()
                continue
            assert p.returncode == -sig, "%s: exit %d: %s" % (what, p.returncode, err)
            interrupted += not cmd.check_interrupted(what)
    print("  %d of %d runs interrupted" % (interrupted, 4 * len(cmds)))
    assert interrupted >= len(cmds), "only %d runs were interrupted" % interrupted


# ------------------------------------------------------------------ resample's loose ends

def test_report_that_cannot_be_written_leaves_no_output():
    """--report is finished (written, flushed, closed) under a temporary
    name before the outputs are renamed: when it cannot be, the run fails
    with nothing renamed, neither the outputs nor the report."""
    src = synth(100_000, "las")
    os.makedirs("rep")
    rep = os.path.abspath("rep")
    faults = [("disk full", dict(WRITE_DIR=rep, WRITE_AFTER=100), "disk full"),
              ("EIO at fsync", dict(SYNC_DIR=rep), "Input/output error"),
              ("loss reported at close", dict(CLOSE_DIR=rep), "disk full")]
    for path_name, extra in PATHS.items():
        for fault, env, says in faults:
            for per_input in (False, True):
                out = "out" if per_input else "out.las"
                c = Case(src, out, 2_000, [*extra, "--report", "rep/r.json"], per_input=per_input)
                c.run(env=preload(**env))
                what = "report: %s, %s%s" % (fault, path_name, ", --per-input" if per_input else "")
                c.check_failed(what, 3, names="rep/r.json", says=(says,))
                assert os.listdir("rep") == [], (what, os.listdir("rep"))
                if per_input:
                    os.rmdir(out)
    # and with nothing failing, both are there
    c = Case(src, "out.las", 2_000, ["--report", "rep/r.json"])
    c.run()
    c.check_succeeded("report, no fault")
    assert os.path.getsize("rep/r.json") > 0


def closes_under(case, folder):
    """Closes of regular files under folder in a clean run of case."""
    count_file = os.path.abspath("close-count")
    case.run(env=preload(CLOSE_DIR=os.path.abspath(folder), CLOSE_AFTER=1 << 60,
                         CLOSE_COUNT=count_file))
    case.check_succeeded("clean run counting closes")
    os.remove(case.out)
    with open(count_file) as f:
        return int(f.read())


def test_spill_file_close_failures_are_io_errors():
    """close() of a spill file reports a loss (storage that reports a full
    disk only then): while tiling (a descriptor evicted from the cache), at
    the end of tiling and after reading a tile back, by the count of closes
    a clean run makes. Exit 3 naming the file. Since issue 12 the samples
    (run files of the sample store and of the result) and the exact count's
    fields (blobs) are written into the same directory, so a close past the
    first may be any of them: each is named for what it is."""
    src = synth(200_000, "las")
    extra = ["--min-tiles", 80]
    total = closes_under(Case(src, "out.las", 5_000, extra), "spill")
    assert total > 80, total
    for after in (0, total // 2, total - 1):
        c = Case(src, "out.las", 5_000, extra)
        c.run(env=preload(CLOSE_DIR=os.path.abspath("spill"), CLOSE_AFTER=after))
        msg = c.check_failed("close %d of %d fails" % (after + 1, total), 3,
                             says=("disk full",))
        spill = "spill file" in msg and "/wpd-spill-" in msg and "/tile-" in msg
        run = "run file" in msg and "/wpd-runs-" in msg and "/run-" in msg
        blob = "/wpd-blobs-" in msg and "/b-" in msg
        assert spill if after == 0 else (spill or run or blob), msg
