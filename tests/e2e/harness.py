"""Minimal end-to-end test harness: tests are functions named test_* in the
modules given to run(); each runs in a fresh temporary directory. Prints
"N passed, N failed" last."""
import os
import shutil
import subprocess
import sys
import tempfile
import traceback

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# WPD_BIN runs the suite against another build (make test-asan: build/asan/wpd).
WPD = os.environ.get("WPD_BIN") or os.path.join(REPO, "wpd")
_sanitized = []


def sanitized():
    """True if the wpd under test is an ASan/UBSan build (make test-asan):
    its memory use is not the program's."""
    if not _sanitized:
        with open(WPD, "rb") as f:
            blob = f.read()
        _sanitized.append(bool(os.environ.get("WPD_ASAN")) or b"__asan_init" in blob
                          or b"__ubsan_handle" in blob)
    return _sanitized[0]
DATA = os.environ.get("WPD_TEST_DATA", os.path.join(REPO, "..", "shared", "data"))


class Skip(Exception):
    pass


def data(*parts):
    """Path of a shared real test file; skips the test when it is missing."""
    p = os.path.join(DATA, *parts)
    if not os.path.exists(p):
        raise Skip("missing " + p)
    return p


def manifest(folder):
    """Rows of DATA/folder/MANIFEST.tsv as dicts."""
    path = data(folder, "MANIFEST.tsv")
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    keys = lines[0].split("\t")
    return [dict(zip(keys, l.split("\t"))) for l in lines[1:] if l.strip()]


def wpd(*args, check=True, env=None):
    """Runs ./wpd; returns CompletedProcess (text). check: exit 0 required."""
    p = subprocess.run([WPD, *map(str, args)], capture_output=True, text=True, env=env)
    if check and p.returncode != 0:
        raise AssertionError("wpd %s -> %d: %s" % (" ".join(map(str, args)), p.returncode,
                                                   p.stderr.strip()))
    return p


def run(modules):
    passed = failed = skipped = 0
    only = sys.argv[1] if len(sys.argv) > 1 else None
    for mod in modules:
        for name in sorted(n for n in dir(mod) if n.startswith("test_")):
            if only and only not in name:
                continue
            tmp = tempfile.mkdtemp(prefix="wpd-e2e-")
            cwd = os.getcwd()
            os.chdir(tmp)
            try:
                getattr(mod, name)()
                print("ok   %s" % name)
                passed += 1
            except Skip as e:
                print("skip %s (%s)" % (name, e))
                skipped += 1
            except Exception:
                print("FAIL %s" % name)
                traceback.print_exc(file=sys.stdout)
                failed += 1
            finally:
                os.chdir(cwd)
                shutil.rmtree(tmp, ignore_errors=True)
            sys.stdout.flush()
    print("%d passed, %d failed" % (passed, failed) + (", %d skipped" % skipped if skipped else ""))
    return 1 if failed else 0
