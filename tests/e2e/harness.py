"""What the end-to-end tests share: the wpd under test, the shared real
data, running wpd, and small real clouds cut from the scans. The tests run
under pytest (conftest.py, docs/testing.md)."""
import os
import struct
import subprocess

import numpy as np
import pytest

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
_coverage = []


def coverage_build():
    """True if the wpd under test writes gcov counts (make coverage): its
    exit handler allocates, so it cannot outlive a failed allocation."""
    if not _coverage:
        with open(WPD, "rb") as f:
            _coverage.append(b"__gcov_" in f.read())
    return _coverage[0]


# A test that cannot run here (a missing file or tool) raises Skip("why").
Skip = pytest.skip.Exception


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


def cut_las(src, dst, fx, fy):
    """Writes to dst the points of LAS file src (point formats 0-10, versions
    1.0-1.4, no EVLRs) that lie in the box from the header's minimum corner
    over the fractions fx and fy of its x and y extents, with the header's
    counts, per-return counts and bounds made true for them."""
    with open(src, "rb") as f:
        blob = f.read()
    header_size, offset = struct.unpack_from("<HI", blob, 94)
    pdrf, reclen, legacy = struct.unpack_from("<BHI", blob, 104)
    version = (blob[24], blob[25])
    count = legacy
    if version >= (1, 4) and header_size >= 375:
        count = struct.unpack_from("<Q", blob, 247)[0] or legacy
    scale = np.array(struct.unpack_from("<3d", blob, 131))
    shift = np.array(struct.unpack_from("<3d", blob, 155))
    mx, mn, my, mny = struct.unpack_from("<4d", blob, 179)
    rec = np.frombuffer(blob, np.uint8, count * reclen, offset).reshape(count, reclen)
    xyz = rec[:, :12].copy().view("<i4").reshape(count, 3) * scale + shift
    keep = (xyz[:, 0] <= mn + fx * (mx - mn)) & (xyz[:, 1] <= mny + fy * (my - mny))
    rec, xyz = rec[keep], xyz[keep]
    head = bytearray(blob[:offset])
    n = len(rec)
    returns = rec[:, 14] & (0x0F if pdrf >= 6 else 0x07)
    by_return = [int(np.count_nonzero(returns == k)) for k in range(1, 16)]
    if version >= (1, 4) and header_size >= 375:
        struct.pack_into("<Q15Q", head, 247, n, *by_return)
    legacy_ok = pdrf < 6 and n < 1 << 32
    struct.pack_into("<I5I", head, 107, n if legacy_ok else 0,
                     *(by_return[:5] if legacy_ok else [0] * 5))
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    struct.pack_into("<6d", head, 179, hi[0], lo[0], hi[1], lo[1], hi[2], lo[2])
    with open(dst, "wb") as f:
        f.write(head)
        f.write(rec.tobytes())
    return n


def slow(*values):
    """A pytest parameter set for the full tier only."""
    return pytest.param(*values, marks=pytest.mark.slow)


NC = "nc_raleigh_lidar_2269213.las"
