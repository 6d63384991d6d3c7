"""Entry point of the end-to-end tests."""
import os
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

sys.exit(harness.run([test_io, test_resample, test_engine, test_cli, test_faults,
                      test_faults_commands, test_driver, test_las_lenient]))
