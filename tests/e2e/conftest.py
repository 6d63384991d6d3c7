"""pytest set-up of the end-to-end tests (docs/testing.md).

Every test runs in a fresh temporary directory of its own (the tests write
their outputs by relative names). Markers: `slow` (the full tier only: `make
test-full`), `serial` (peak memory, signals and timing: never beside another
test), `quality` (numeric quality checks) and `rss` (peak memory), neither
repeated under the sanitizers. The small real clouds the fast tier runs on
are cut once per worker process (`nc_cut`)."""
import os
import signal

import pytest

import harness

# The signal tests check what a signal does to wpd, which leaves a signal
# the process ignores ignored (nohup). A suite started in the background by
# a non-interactive shell (SIGINT ignored) or under nohup (SIGHUP) would hand
# that on to every wpd it starts: the default actions are restored first.
for _sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    if signal.getsignal(_sig) == signal.SIG_IGN:
        signal.signal(_sig, signal.SIG_DFL)


def pytest_configure(config):
    for line in ("slow: the full tier (make test-full): every-scan sweeps, large clouds, "
                 "random-moment signals, MPI at 4 ranks",
                 "serial: measures peak memory, sends signals or times runs: run alone",
                 "quality: checks quality figures (not run under the sanitizers)",
                 "rss: measures peak memory (not run under the sanitizers, whose memory is "
                 "not the program's)"):
        config.addinivalue_line("markers", line)


@pytest.fixture(autouse=True)
def _fresh_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


@pytest.fixture(scope="session")
def nc_cut(tmp_path_factory):
    """A real airborne cloud small enough for the fast tier: the NC Raleigh
    scan's points in a box at its minimum corner (206 K of its 2.27 M
    points, buildings, trees and ground), as LAS 1.2 point format 3."""
    src = harness.data("scans", "nc_raleigh_lidar_2269213.las")
    dst = str(tmp_path_factory.mktemp("clouds") / "nc_cut.las")
    harness.cut_las(src, dst, 0.2, 0.3)
    os.chmod(dst, 0o444)
    return dst


@pytest.fixture
def scan(request):
    """scan(name): the path of a shared scan, or of the fast tier's cut of
    NC Raleigh for the name "nc_cut"."""
    def resolve(name):
        if name == "nc_cut":
            return request.getfixturevalue("nc_cut")
        return harness.data("scans", name)
    return resolve
