#!/usr/bin/env bash
# Runs every test: the C unit tests, then the end-to-end tests (Python, using
# the built ./wpd). Prints one closing line "N passed, N failed" and exits
# non-zero on any failure.
set -u
cd "$(dirname "$0")/.."
log=$(mktemp -d)
trap 'rm -rf "$log"' EXIT

total_pass=0 total_fail=0
run_suite() {  # name, command...
    local name=$1; shift
    echo "== $name"
    "$@" 2>&1 | tee "$log/$name.out"
    local rc=${PIPESTATUS[0]}
    local line p f
    line=$(grep -E '^[0-9]+ passed, [0-9]+ failed' "$log/$name.out" | tail -n 1)
    if [ -z "$line" ]; then
        echo "suite $name printed no summary (exit $rc)"; p=0; f=1
    else
        p=${line%% passed*}; f=${line#*, }; f=${f%% failed*}
        if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi
    fi
    total_pass=$((total_pass + p)); total_fail=$((total_fail + f))
}

run_suite unit "${WPD_UNIT_TESTS:-build/unit_tests}"   # test-asan: sanitized build
run_suite e2e /usr/bin/python3 tests/e2e/run.py

echo "$total_pass passed, $total_fail failed"
[ "$total_fail" -eq 0 ]
