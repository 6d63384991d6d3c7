"""Fault injection: truncated inputs, read errors, a full disk while
spilling and while writing, failing allocations, kills at random moments.
Every fault must end with its documented exit code and a one-line message,
no output under the final name, no temporary output, lock or spill
directory left behind, and the inputs unchanged (sha256 before and after).
Both paths run: the cloud in memory and the out-of-core engine (--min-tiles).

Read, write, sync/close and allocation faults come from tests/fault/fault.c,
an LD_PRELOAD interposer compiled here with `cc -shared -fPIC` (those tests
skip when there is no compiler; under a sanitizer build, whose allocator
must stay its own, only the allocation tests skip). The full disk is a
small tmpfs when mount works (root), else the interposer; a file size
limit is also tested. Signals land at the named stop points of
src/common/testhook.h (the fast tier) or at random moments (the full tier).
Random choices are seeded: the seed is printed and WPD_FAULT_SEED=S repeats
them. With WPD_FAULT_RECORD=FILE every run's outcome is appended to FILE
(tests/replay_faults.sh compares two runs of the suite)."""
import atexit
import hashlib
import json
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import tempfile
import time

import pytest

from formats import read_las, read_ply
from harness import DATA, REPO, WPD, Skip, coverage_build, sanitized

# Both paths of `wpd resample`: every fault runs through each.
PATHS = {"memory": [], "engine": ["--min-tiles", "4"]}

_cache = {}


def _cache_dir():
    if "dir" not in _cache:
        _cache["dir"] = tempfile.mkdtemp(prefix="wpd-faults-")
        atexit.register(shutil.rmtree, _cache["dir"], True)
    return _cache["dir"]


def synth(n, ext, ascii_ply=False, seed=1):
    """A synthetic scan of n points, made once per test run."""
    key = (n, ext, ascii_ply, seed)
    if key not in _cache:
        path = os.path.join(_cache_dir(), "synth_%d_%d%s.%s" % (n, seed, "_a" if ascii_ply else "",
                                                               ext))
        args = ["synth", "-n", n, "-o", path, "--seed", seed] + (["--ascii"] if ascii_ply else [])
        subprocess.run([WPD, *map(str, args)], check=True, capture_output=True)
        os.chmod(path, 0o444)  # a test that writes to it fails loudly
        _cache[key] = path
    return _cache[key]


def asan_runtime():
    """The ASan runtime wpd is linked with (it must come first in
    LD_PRELOAD), or None."""
    p = subprocess.run(["ldd", WPD], capture_output=True, text=True)
    for line in p.stdout.splitlines():
        if "libasan" in line and "=>" in line:
            return line.split("=>")[1].split()[0]
    return None


def interposer(alloc=False):
    """LD_PRELOAD value loading tests/fault/fault.c (compiled here once);
    skips the test when it cannot be built or used. Under a sanitizer build
    only the I/O faults are compiled in, after the ASan runtime: the
    allocator must stay the sanitizer's."""
    if sanitized() and alloc:
        raise Skip("wpd is a sanitizer build: allocation faults would replace its allocator")
    if coverage_build() and alloc:
        raise Skip("wpd is a coverage build: gcov's exit handler cannot outlive a failed "
                   "allocation")
    key = "so-io" if sanitized() else "so"
    if key not in _cache:
        cc = os.environ.get("CC", "cc")
        if not shutil.which(cc):
            raise Skip("no C compiler (%s) to build the fault interposer tests/fault/fault.c" % cc)
        so = os.path.join(_cache_dir(), key + ".so")
        src = os.path.join(REPO, "tests", "fault", "fault.c")
        flags = ["-DFAULT_NO_ALLOC"] if sanitized() else []
        p = subprocess.run([cc, "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-Werror", *flags,
                            "-o", so, src], capture_output=True, text=True)
        assert p.returncode == 0, "cannot build %s: %s" % (src, p.stderr)
        if sanitized():
            runtime = asan_runtime()
            if not runtime:
                raise Skip("sanitizer build without a shared ASan runtime to preload first")
            so = runtime + ":" + so
        _cache[key] = so
    return _cache[key]


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def leftovers(*dirs):
    """Spill, run, blob and record cache directories, temporary outputs and
    lock files in dirs."""
    return [os.path.join(d, f) for d in dirs for f in os.listdir(d)
            if f.startswith(("wpd-spill-", "wpd-runs-", "wpd-blobs-", "wpd-cache-"))
            or ".wpd-tmp-" in f or f.endswith(".wpd-lock")]


def normalised(text):
    """text with what differs between two runs of one case made alike: the
    test's and the cache's directories, and the process ids and random
    letters in the names of temporary files."""
    text = text.replace(os.getcwd(), "<test>").replace(_cache_dir(), "<cache>")
    return re.sub(r"(wpd-(?:spill|runs|blobs|cache)-|\.wpd-tmp-)[^/\s'\"]+", r"\1*", text)


def record(args, returncode, stderr):
    """With WPD_FAULT_RECORD=FILE: appends one JSON line to FILE with the
    test, the command, its exit code, its standard error and every file then
    under the test's directory (names normalised())."""
    path = os.environ.get("WPD_FAULT_RECORD")
    if not path:
        return
    files = sorted(normalised(os.path.join(d, f)) for d, _, fs in os.walk(os.getcwd())
                   for f in fs)
    line = {"test": os.environ.get("PYTEST_CURRENT_TEST", "").split(" ")[0],
            "args": normalised(" ".join(map(str, args))), "exit": returncode,
            "stderr": normalised(stderr), "files": files}
    with open(path, "a") as f:
        f.write(json.dumps(line) + "\n")


def run(args, env=None, preexec_fn=None, timeout=120):
    full_env = dict(os.environ, **(env or {}))
    p = subprocess.run([WPD, *map(str, args)], capture_output=True, text=True, env=full_env,
                       preexec_fn=preexec_fn, timeout=timeout)
    record(args, p.returncode, p.stderr)
    return p


def stop_at(args, stop, sig):
    """Runs `wpd ARGS` until it stalls at the named stop point (testhook.h),
    sends sig, and returns (exit code, standard error) once it has ended."""
    p = subprocess.Popen([WPD, *map(str, args)], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, WPD_TEST_STALL=stop))
    line = p.stderr.readline()
    assert "stalled at " + stop in line, (stop, line)
    p.send_signal(sig)
    err = line + p.stderr.read()
    p.wait(timeout=60)
    p.stderr.close()
    record([*args, "(%s at %s)" % (sig.name, stop)], p.returncode, err)
    return p.returncode, err


def preload(**faults):
    """Environment that loads the interposer with the given WPD_FAULT_* settings."""
    env = {"LD_PRELOAD": interposer(alloc=any(k.startswith("MALLOC") for k in faults))}
    env.update({"WPD_FAULT_" + k: str(v) for k, v in faults.items()})
    return env


def point_count(path):
    if path.endswith(".las"):
        h = read_las(path)
        assert len(h["points"]) == h["count"] * h["record_length"], path + ": short point block"
        return h["count"]
    return len(read_ply(path)[1])


def synth_tiles(n, k):
    """n synthetic points in k LAS files (one per cell of a grid)."""
    key = ("tiles", n, k)
    if key not in _cache:
        base = os.path.join(_cache_dir(), "tiles_%d_%d.las" % (n, k))
        subprocess.run([WPD, "synth", "-n", str(n), "--tiles", str(k), "-o", base], check=True,
                       capture_output=True)
        paths = [base[:-4] + "_tile%d.las" % i for i in range(1, k + 1)]
        for p in paths:
            os.chmod(p, 0o444)
        _cache[key] = paths
    return _cache[key]


def check_one_line(p, what, code, command, names=None, says=()):
    """p (a finished run of `wpd command`) exited with code and printed one
    line on stderr, "wpd COMMAND: " then `names` (if given), holding every
    string of says. Returns the line."""
    assert p.returncode == code, "%s: exit %d, want %d: %s" % (what, p.returncode, code,
                                                               p.stderr.strip())
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, "%s: want one line, got %r" % (what, p.stderr)
    msg, prefix = lines[0], "wpd %s: " % command
    assert msg.startswith(prefix), (what, msg)
    if names:
        assert msg[len(prefix):].startswith(names), (
            "%s: message does not start with %s: %s" % (what, names, msg))
    for s in says:
        assert s in msg, "%s: message lacks %r: %s" % (what, s, msg)
    return msg


class Case:
    """One faulted run: inputs hashed first, then checked after."""

    def __init__(self, inputs, out, n, extra=(), spill="spill", per_input=False):
        """out is the output file, or with per_input the output folder."""
        self.inputs = inputs if isinstance(inputs, list) else [inputs]
        self.out, self.n, self.spill, self.per_input = out, n, spill, per_input
        os.makedirs(spill, exist_ok=True)
        if per_input:
            os.makedirs(out, exist_ok=True)
        self.args = ["resample", *self.inputs, "--per-input" if per_input else "-o", out,
                     "-n", n, "--tmpdir", spill, "--threads", 1, *extra]
        self.before = {p: sha256(p) for p in self.inputs}

    def outputs(self):
        if self.per_input:
            return [os.path.join(self.out, os.path.basename(p)) for p in self.inputs]
        return [self.out]

    def run(self, **kw):
        self.p = run(self.args, **kw)
        return self.p

    def check_clean(self, what):
        """No output, no temporary output, lock or spill; inputs unchanged.
        With --per-input none of the outputs: they appear together or not."""
        out_dir = os.path.dirname(self.out) or "."
        for out in self.outputs():
            assert not os.path.exists(out), "%s: partial output %s left" % (what, out)
        left = leftovers(out_dir, self.spill, *([self.out] if self.per_input else []))
        assert left == [], "%s: left behind %s" % (what, left)
        assert os.listdir(self.spill) == [], "%s: spill dir holds %s" % (what, os.listdir(self.spill))
        for p, h in self.before.items():
            assert sha256(p) == h, "%s: input %s changed" % (what, p)

    def check_failed(self, what, code, names=None, says=()):
        """Exit code, one message line naming `names` first, then clean."""
        msg = check_one_line(self.p, what, code, "resample", names, says)
        self.check_clean(what)
        return msg

    def check_succeeded(self, what):
        p = self.p
        assert p.returncode == 0, "%s: exit %d: %s" % (what, p.returncode, p.stderr.strip())
        assert sum(point_count(o) for o in self.outputs()) == self.n, what
        assert leftovers(os.path.dirname(self.out) or ".", self.spill) == [], what
        for path, h in self.before.items():
            assert sha256(path) == h, "%s: input %s changed" % (what, path)


# ------------------------------------------------------------------ truncated inputs

def truncate_copy(src, dst, size):
    with open(src, "rb") as f:
        blob = f.read(size)
    with open(dst, "wb") as f:
        f.write(blob)
    return dst


def point_start(path):
    """Byte offset of the first point record (LAS) or vertex (PLY)."""
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    if head[:4] == b"LASF":
        return int.from_bytes(head[96:100], "little")
    end = head.index(b"end_header")
    return head.index(b"\n", end) + 1


def cuts(path):
    """Truncation points inside the points: mid-record, and at a record or
    line boundary (a file that simply stops early)."""
    size, start = os.path.getsize(path), point_start(path)
    mid = start + (size - start) // 2
    if path.endswith(".las"):
        with open(path, "rb") as f:
            f.seek(105)
            reclen = int.from_bytes(f.read(2), "little")
        return {"mid-record": mid - (mid - start) % reclen + reclen // 2,
                "record boundary": mid - (mid - start) % reclen}
    with open(path, "rb") as f:
        f.seek(mid)
        chunk = f.read(4096)
    if b"ascii" in open(path, "rb").read(200):
        line_end = mid + chunk.index(b"\n") + 1
        return {"mid-line": line_end - 3, "line boundary": line_end}
    return {"mid-record": mid + 1, "late": start + (size - start) * 9 // 10}


def parallel_reads(path_name, extra):
    """The engine's options with two threads: its last pass over the
    inputs then reads them from two threads at once, each with its own
    readers, and their failures must come out the same way."""
    return [*extra, "--threads", 2] if path_name == "engine" else extra


def test_truncated_inputs_are_input_errors():
    files = [synth(100_000, "las"), synth(100_000, "ply"), synth(30_000, "ply", ascii_ply=True)]
    real = [os.path.join(DATA, "scans", "lone-star_tile1.las"),
            os.path.join(DATA, "scans", "pcldata_terrain_CSite1_red1-utm.ply"),
            os.path.join(DATA, "ply", "potree_ripple_ascii.ply")]
    present = [p for p in real if os.path.exists(p)]
    print("  real files truncated: %d of %d present in %s" % (len(present), len(real), DATA))
    runs = 0
    for src in files + present:
        ext = os.path.splitext(src)[1]
        for cut_name, size in cuts(src).items():
            bad = truncate_copy(src, "cut_%s%s" % (cut_name.replace(" ", "_"), ext), size)
            for path_name, extra in PATHS.items():
                what = "%s cut at %d (%s), %s" % (os.path.basename(src), size, cut_name,
                                                  path_name)
                c = Case(bad, "out.las", 500, extra)
                c.run()
                c.check_failed(what, 2, names=bad)
                runs += 1
            os.remove(bad)
    assert runs >= 12


def bytes_read(src, extra):
    """Bytes a clean run reads from src (all passes): faults are placed at
    fractions of it, so each lands in a run whatever passes it makes."""
    c = Case(src, "out.las", 500, extra)
    count_file = os.path.abspath("read-count")
    c.run(env=preload(READ_FILE=src, READ_COUNT=count_file))
    c.check_succeeded("clean run counting reads")
    os.remove("out.las")
    with open(count_file) as f:
        return int(f.read())


def test_input_that_shrinks_while_read_is_an_input_error():
    """The header promised more than the file holds when read: the reads
    end early (the file was truncated by another program mid-run), in the
    first pass over the input or in a later one of the engine."""
    for src in (synth(50_000, "las"), synth(50_000, "ply"),
                synth(30_000, "ply", ascii_ply=True)):
        for path_name, extra in PATHS.items():
            extra = parallel_reads(path_name, extra)
            total = bytes_read(src, extra)
            for frac in (0.3, 0.6, 0.95):
                after = int(total * frac)
                what = "%s ends after %d of %d bytes read, %s" % (os.path.basename(src), after,
                                                                 total, path_name)
                c = Case(src, "out.las", 500, extra)
                c.run(env=preload(READ_FILE=src, READ_AFTER=after, READ_EOF=1))
                c.check_failed(what, 2, names=src, says=("ends",))


# ------------------------------------------------------------------ read errors

def test_read_error_is_an_io_error_naming_the_file():
    for src in (synth(50_000, "las"), synth(50_000, "ply"),
                synth(30_000, "ply", ascii_ply=True)):
        for path_name, extra in PATHS.items():
            extra = parallel_reads(path_name, extra)
            total = bytes_read(src, extra)
            # in the header, then spread over the passes
            for after in (100, *(int(total * f) for f in (0.25, 0.5, 0.75, 0.97))):
                what = "%s EIO after %d of %d bytes read, %s" % (os.path.basename(src), after,
                                                                total, path_name)
                c = Case(src, "out.las", 500, extra)
                c.run(env=preload(READ_FILE=src, READ_AFTER=after))
                c.check_failed(what, 3, names=src, says=("Input/output error",))


# ------------------------------------------------------------------ disk full

class FullDisk:
    """A directory that holds at most `size` bytes: a tmpfs when mount
    works here, else the interposer's ENOSPC after `size` bytes."""

    def __init__(self, path, size):
        self.path, self.size, self.mounted = path, size, False
        os.makedirs(path)
        if os.geteuid() == 0 and shutil.which("mount"):
            p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=%d,mode=0755" % size,
                                "wpd-test-full", path], capture_output=True, text=True)
            self.mounted = p.returncode == 0
        if not self.mounted:
            self.env = preload(WRITE_DIR=os.path.abspath(path), WRITE_AFTER=size)
        else:
            self.env = {}
        self.means = ("a %d KiB tmpfs" % (size >> 10) if self.mounted else
                      "the LD_PRELOAD interposer (ENOSPC after %d KiB; no tmpfs mount here)"
                      % (size >> 10))

    def close(self):
        if self.mounted:
            if subprocess.run(["umount", self.path]).returncode != 0:
                subprocess.run(["umount", "-l", self.path])
            self.mounted = False


def test_disk_full_while_spilling_and_while_writing():
    src = synth(200_000, "las")
    full = FullDisk("full", 64 << 10)
    try:
        print("  full disk: " + full.means)
        # spilling: the spill directory is on the full disk
        c = Case(src, "out.las", 10_000, PATHS["engine"], spill="full")
        c.run(env=full.env)
        msg = c.check_failed("spilling onto a full disk", 3, says=("disk full",))
        assert "spill" in msg, msg
        # writing: the output is on the full disk, in every output format
        for out in ("full/out.las", "full/out.ply"):
            for ascii_ply in ([], ["--ascii"]) if out.endswith(".ply") else ([],):
                for path_name, extra in PATHS.items():
                    what = "writing %s%s onto a full disk, %s" % (out, " ascii" if ascii_ply else "",
                                                                 path_name)
                    c = Case(src, out, 10_000, [*extra, *ascii_ply])
                    c.run(env=full.env)
                    c.check_failed(what, 3, names=out, says=("disk full",))
                    if full.mounted:
                        assert os.listdir("full") == [], os.listdir("full")
    finally:
        full.close()


def test_per_input_outputs_appear_together_or_not_at_all():
    """--per-input: the disk fills after the first outputs are complete.
    None may stay: with --skip-existing the next run would resample the
    other inputs on their own (a seam, another count)."""
    tiles = synth_tiles(150_000, 3)
    full = FullDisk("full", 512 << 10)  # one output of ~340 KB fits, not three
    try:
        print("  full disk: " + full.means)
        for path_name, extra in PATHS.items():
            c = Case(tiles, "full", 30_000, extra, per_input=True)
            c.run(env=full.env)
            c.check_failed("--per-input onto a full disk, " + path_name, 3, names="full/",
                           says=("disk full",))
            assert os.listdir("full") == [], os.listdir("full")
            c = Case(tiles, "out", 30_000, extra, per_input=True)  # and the disk is fine
            c.run()
            c.check_succeeded("--per-input, " + path_name)
            shutil.rmtree("out")
    finally:
        full.close()
    # two inputs of one name would write one output: refused before any work
    os.makedirs("a")
    os.makedirs("b")
    for d in ("a", "b"):
        shutil.copy(tiles[0], d)
    c = Case(["a/" + os.path.basename(tiles[0]), "b/" + os.path.basename(tiles[0])], "out",
             1000, per_input=True)
    c.run()
    c.check_failed("two inputs of one name", 1, says=("would both write it",))


def test_file_size_limit_is_disk_full_not_a_signal():
    """RLIMIT_FSIZE with SIGXFSZ at its default action (which kills): wpd
    ignores the signal itself, so the write fails with EFBIG and the run
    ends like on a full disk."""
    src = synth(200_000, "las")

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_DFL)
        resource.setrlimit(resource.RLIMIT_FSIZE, (64 << 10, 64 << 10))

    for path_name, extra in PATHS.items():
        c = Case(src, "out.las", 10_000, extra)
        c.run(preexec_fn=limit)
        c.check_failed("file size limit, " + path_name, 3, says=("disk full or file size limit",))


def test_errors_reported_only_by_fsync_or_close():
    """Storage that accepts every write and reports the loss at fsync or
    close (NFS, quotas): the output must not be renamed into place."""
    src = synth(100_000, "las")
    os.makedirs("outdir")
    for fault, says in (({"SYNC_DIR": os.path.abspath("outdir")}, "Input/output error"),
                        ({"CLOSE_DIR": os.path.abspath("outdir")}, "disk full")):
        for path_name, extra in PATHS.items():
            for out in ("outdir/out.las", "outdir/out.ply"):
                what = "%s, %s, %s" % (list(fault)[0], out, path_name)
                c = Case(src, out, 5_000, extra)
                c.run(env=preload(**fault))
                c.check_failed(what, 3, names=out, says=(says,))


# ------------------------------------------------------------------ allocation failures

def allocation_count(case, env):
    count_file = os.path.abspath("alloc-count")
    case.run(env=dict(env, **preload(MALLOC_COUNT=count_file)))
    assert case.p.returncode == 0, case.p.stderr
    os.remove(case.out)
    with open(count_file) as f:
        return int(f.read())


def test_allocation_failures_end_cleanly_in_every_phase():
    """The N-th allocation fails (once, or from then on), for 20 values of N
    spread over the whole run, on both paths: exit 4 with a message about
    memory, or success when the failure was absorbed (sorting falls back,
    sweeps are best effort); never a crash, and cleanup holds."""
    src = synth(30_000, "las")
    seed = random.randrange(1 << 30)
    seed = int(os.environ.get("WPD_FAULT_SEED", seed))
    print("  seed %d (WPD_FAULT_SEED=%d reproduces)" % (seed, seed))
    rng = random.Random(seed)
    outcomes = {}
    for path_name, extra in PATHS.items():
        total = allocation_count(Case(src, "out.las", 5_000, extra), {})
        assert total > 50, total
        for i in range(20):
            lo, hi = i * total // 20 + 1, (i + 1) * total // 20
            n = rng.randint(lo, max(lo, hi))
            always = i % 2
            what = "%s, allocation %d of %d fails%s" % (path_name, n, total,
                                                        " and every later one" if always else "")
            c = Case(src, "out.las", 5_000, extra)
            c.run(env=preload(MALLOC_FAIL=n, MALLOC_ALWAYS=always))
            rc = c.p.returncode
            outcomes[rc] = outcomes.get(rc, 0) + 1
            assert rc >= 0, "%s: killed by signal %d: %s" % (what, -rc, c.p.stderr)
            if rc == 0:
                c.check_succeeded(what)
                os.remove(c.out)
                continue
            lines = [l for l in c.p.stderr.splitlines() if l.strip()]
            assert rc == 4, "%s: exit %d: %s" % (what, rc, c.p.stderr.strip())
            # libgomp prints its own line ("libgomp: Out of memory ...")
            # before exiting; wpd turns that exit into 4.
            assert len(lines) == 1 and "memory" in lines[0].lower(), (what, c.p.stderr)
            c.check_clean(what)
    print("  exit codes over 40 runs: %s" % sorted(outcomes.items()))
    assert outcomes.get(4, 0) >= 20, outcomes


def test_one_large_allocation_failing_is_exit_4():
    src = synth(200_000, "las")
    for path_name, extra in PATHS.items():
        for above in (256 << 10, 4 << 20):
            c = Case(src, "out.las", 5_000, extra)
            c.run(env=preload(MALLOC_ABOVE=above))
            c.check_failed("%s, allocations >= %d bytes fail" % (path_name, above), 4,
                           says=("memory",))


# ------------------------------------------------------------------ signals

def timed_baseline(args):
    t = time.monotonic()
    p = run(args)
    assert p.returncode == 0, p.stderr
    return time.monotonic() - t


def synth_laz(n):
    """synth(n, "las") compressed (LAZ: its runs keep a record cache)."""
    key = ("laz", n)
    if key not in _cache:
        path = synth(n, "las")[:-4] + ".laz"
        subprocess.run([WPD, "convert", synth(n, "las"), path], check=True, capture_output=True)
        os.chmod(path, 0o444)
        _cache[key] = path
    return _cache[key]


def random_signal_case(ext="las"):
    """An engine run to interrupt, a seeded random source (the seed is
    printed; WPD_FAULT_SEED repeats it) and how long the run takes
    uninterrupted."""
    src = synth_laz(1_000_000) if ext == "laz" else synth(1_000_000, "las")
    seed = int(os.environ.get("WPD_FAULT_SEED", random.randrange(1 << 30)))
    rng = random.Random(seed)
    c = Case(src, "out.las", 20_000, ["--min-tiles", 8])
    base = timed_baseline(c.args)
    os.remove("out.las")
    print("  seed %d (WPD_FAULT_SEED reproduces), uninterrupted run %.2f s" % (seed, base))
    return c, rng, base


# The named stop points of a resample run through tiles, in order.
STOPS = ("scan", "tile", "poisson", "exact", "smooth", "merge", "records", "write")


@pytest.mark.serial
@pytest.mark.parametrize("ext", ["las", "laz"])
def test_signals_at_every_stop_point_leave_nothing(ext):
    """At each stop point of a run through tiles, SIGTERM, SIGINT or SIGHUP
    (in turn) ends it by that signal with nothing left (no output, spill,
    run or blob files, record cache, temporary output or lock); SIGKILL
    leaves what it leaves, and the next run removes it and finishes."""
    src = synth_laz(50_000) if ext == "laz" else synth(50_000, "las")
    # LAZ: where the record cache is being written, kept, and read back
    for k, stop in enumerate(STOPS if ext == "las" else ("scan", "tile", "records")):
        for sig in ((signal.SIGTERM, signal.SIGINT, signal.SIGHUP)[k % 3], signal.SIGKILL):
            what = "%s at %s, %s input" % (sig.name, stop, ext)
            c = Case(src, "out.las", 5_000, ["--min-tiles", 4])
            rc, err = stop_at(c.args, stop, sig)
            assert rc == -sig, "%s: exit %d: %s" % (what, rc, err)
            if sig != signal.SIGKILL:
                c.check_clean(what)
                continue
            assert not os.path.exists("out.las"), what
            c.run()
            c.check_succeeded("the run after " + what)
            assert os.listdir(c.spill) == [], (what, os.listdir(c.spill))
            os.remove("out.las")


@pytest.mark.slow
@pytest.mark.serial
def test_sigterm_and_sigint_at_random_moments_leave_nothing():
    c, rng, base = random_signal_case()
    interrupted = 0
    for k in range(8):
        sig = (signal.SIGTERM, signal.SIGINT)[k % 2]
        delay = rng.uniform(0.02, 0.9) * base
        what = "%s after %.3f s" % (sig.name, delay)
        p = subprocess.Popen([WPD, *map(str, c.args)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
        # finished first, or the signal came after the rename, on the way
        # out (slow under ASan, whose leak check runs at exit): complete
        if p.returncode == 0 or (p.returncode == -sig and os.path.exists("out.las")):
            assert point_count("out.las") == 20_000, what
            assert leftovers(".", "spill") == [], what
            os.remove("out.las")
            continue
        assert p.returncode == -sig, "%s: exit %d: %s" % (what, p.returncode, err)
        interrupted += 1
        c.check_clean(what)
    print("  %d of 8 runs interrupted" % interrupted)
    # the baseline may be timed while the machine is busier than later:
    # runs that finish first are checked above; a few must land
    assert interrupted >= 3, "only %d of 8 runs were interrupted" % interrupted
    # --per-input: the outputs appear together or not at all
    c = Case(synth_tiles(1_000_000, 4), "out", 20_000, ["--min-tiles", 8], per_input=True)
    base = timed_baseline(c.args)
    shutil.rmtree("out")
    interrupted = 0
    for k in range(4):
        sig = (signal.SIGTERM, signal.SIGINT)[k % 2]
        delay = rng.uniform(0.5, 1.0) * base  # the later half, where the writing is
        os.makedirs("out")
        p = subprocess.Popen([WPD, *map(str, c.args)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
        what = "--per-input, %s after %.3f s" % (sig.name, delay)
        if p.returncode == 0 or (p.returncode == -sig and os.listdir("out")):
            assert sum(point_count(o) for o in c.outputs()) == 20_000, what
        else:
            assert p.returncode == -sig, "%s: exit %d: %s" % (what, p.returncode, err)
            interrupted += 1
            c.check_clean(what)
        shutil.rmtree("out")
    print("  --per-input: %d of 4 runs interrupted" % interrupted)


@pytest.mark.serial
def test_signals_before_the_per_input_renames_leave_nothing():
    """20 outputs finished under temporary names, none renamed (more than
    the signal handlers' registry holds one by one): SIGTERM, SIGINT and
    SIGHUP remove them all; after SIGKILL the next run does."""
    tiles = synth_tiles(100_000, 20)
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGKILL):
        c = Case(tiles, "out", 10_000, PATHS["engine"], per_input=True)
        p = subprocess.Popen([WPD, *map(str, c.args)], stderr=subprocess.PIPE, text=True,
                             env=dict(os.environ, WPD_TEST_STALL="per-input"))
        line = p.stderr.readline()
        assert "stalled at per-input" in line, line
        pending = [f for f in os.listdir("out") if ".wpd-tmp-" in f]
        assert len(pending) == 20, pending
        p.send_signal(sig)
        assert p.wait(timeout=30) == -sig, (sig.name, p.returncode)
        p.stderr.close()
        if sig == signal.SIGKILL:
            assert len(leftovers("out")) == 20  # nothing could clean up
            c.run(env={"WPD_TEST_STALL": ""})
            c.check_succeeded("the run after SIGKILL")
        else:
            c.check_clean(sig.name)


@pytest.mark.serial
def test_failures_in_the_records_pass_leave_no_run_file():
    """The samples' runs (files of their own when tiled, issue 12) exist
    from the end of the run to the end of the records pass: a read error
    there, a full output disk, SIGTERM and SIGINT remove them; after
    SIGKILL the next run sweeps them."""
    src = synth(100_000, "las")
    extra = ["--min-tiles", 4, "--class-count", "2=2000"]
    for classes in (False, True):
        args = extra if classes else extra[:2]
        c = Case(src, "out.las", 5_000, args)
        c.run(env=preload(READ_FILE=src, READ_COUNT=os.path.abspath("read-count")))
        assert c.p.returncode == 0 and leftovers(".", c.spill) == [], c.p.stderr
        os.remove("out.las")
        with open("read-count") as f:
            total = int(f.read())
        size = os.path.getsize(src)
        what = "EIO half way through the records pass%s" % (" (by class)" if classes else "")
        c = Case(src, "out.las", 5_000, args)
        c.run(env=preload(READ_FILE=src, READ_AFTER=total - size // 2))
        c.check_failed(what, 3, names=src, says=("Input/output error",))
        full = FullDisk("full", 64 << 10)
        try:
            c = Case(src, "full/out.las", 5_000, args)
            c.run(env=full.env)
            c.check_failed("a full disk in the records pass", 3, names="full/out.las",
                           says=("disk full",))
        finally:
            full.close()
            shutil.rmtree("full", ignore_errors=True)
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGKILL):
        c = Case(src, "out.las", 5_000, extra)
        p = subprocess.Popen([WPD, *map(str, c.args)], stderr=subprocess.PIPE, text=True,
                             env=dict(os.environ, WPD_TEST_STALL="records"))
        line = p.stderr.readline()
        assert "stalled at records" in line, line
        runs = [f for f in os.listdir(c.spill) if f.startswith("wpd-runs-")]
        assert len(runs) == 2 and all(os.listdir(os.path.join(c.spill, d)) for d in runs), runs
        p.send_signal(sig)
        assert p.wait(timeout=30) == -sig, (sig.name, p.returncode)
        p.stderr.close()
        if sig == signal.SIGKILL:
            assert len(leftovers(c.spill)) == 2  # nothing could clean up
            c.run(env={"WPD_TEST_STALL": ""})
            assert c.p.returncode == 0, c.p.stderr
            assert point_count("out.las") == 7_000  # the rest's 5 000 and class 2's 2 000
            assert os.listdir(c.spill) == [] and leftovers(".") == [], os.listdir(c.spill)
        else:
            c.check_clean(sig.name)


@pytest.mark.slow
@pytest.mark.serial
def test_sigkill_at_random_moments_then_the_next_run_sweeps():
    sigkill_then_sweep("las")


@pytest.mark.slow
@pytest.mark.serial
def test_sigkill_of_a_laz_run_then_the_next_run_sweeps_its_record_cache():
    sigkill_then_sweep("laz")


def sigkill_then_sweep(ext):
    c, rng, base = random_signal_case(ext)
    swept = 0
    for k in range(4):
        delay = rng.uniform(0.05, 0.95) * base
        what = "SIGKILL after %.3f s" % delay
        p = subprocess.Popen([WPD, *map(str, c.args)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        time.sleep(delay)
        p.kill()
        p.wait(timeout=60)
        if os.path.exists("out.las"):  # renamed into place: complete
            assert point_count("out.las") == 20_000, what
        swept += bool(leftovers(".", "spill"))
        # the next run replaces it and removes what the dead one left
        p2 = run([*c.args, "--force"])
        assert p2.returncode == 0, "%s, next run: %s" % (what, p2.stderr)
        assert point_count("out.las") == 20_000, what
        assert leftovers(".", "spill") == [], (what, leftovers(".", "spill"))
        assert os.listdir("spill") == [], what
        os.remove("out.las")
    print("  %d of 4 kills left a spill, temporary output or lock for the next run" % swept)
    assert swept >= 1, "no kill landed while there was something to sweep"
    for path, h in c.before.items():
        assert sha256(path) == h
