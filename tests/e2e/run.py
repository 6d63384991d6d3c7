"""Entry point of the end-to-end tests."""
import os
import signal
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import harness  # noqa: E402
import test_io  # noqa: E402
import test_resample  # noqa: E402
import test_engine  # noqa: E402
import test_cli  # noqa: E402
import test_faults  # noqa: E402
import test_faults_commands  # noqa: E402
import test_driver  # noqa: E402
import test_las_lenient  # noqa: E402
import test_edges  # noqa: E402
import test_classes  # noqa: E402
import test_laz  # noqa: E402
import test_laz_write  # noqa: E402
import test_mpi  # noqa: E402

# The signal tests check what a signal does to wpd, which leaves a signal
# the process ignores ignored (nohup). A suite started in the background by
# a non-interactive shell (SIGINT ignored) or under nohup (SIGHUP) would hand
# that on to every wpd it starts: the default actions are restored first.
for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    if signal.getsignal(sig) == signal.SIG_IGN:
        signal.signal(sig, signal.SIG_DFL)

sys.exit(harness.run([test_io, test_resample, test_engine, test_cli, test_faults,
                      test_faults_commands, test_driver, test_las_lenient, test_edges, test_classes,
                      test_laz, test_laz_write, test_mpi]))
