#!/usr/bin/env bash
# make test-asan: the fast tier without its quality checks (tests/run.sh
# asan: unit + e2e, the fault tests among them) against the AddressSanitizer
# + UndefinedBehaviorSanitizer build in DIR (build/asan).
#
#   tests/asan.sh [DIR]
#
# Every sanitizer report, from any process (the unit tests, or a wpd run by
# an e2e test), is written to DIR/reports/ and counts as one more failure:
# an e2e test that only checks an exit code would otherwise let a report
# through. Leak checking is on; allocation failures return NULL as they do
# without ASan (the program handles them).
set -u
cd "$(dirname "$0")/.."
dir=${1:-build/asan}
reports="$PWD/$dir/reports"
rm -rf "$reports"
mkdir -p "$reports"
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:allocator_may_return_null=1:log_path=$reports/asan"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:log_path=$reports/ubsan"
export WPD_BIN="$PWD/$dir/wpd" WPD_UNIT_TESTS="$PWD/$dir/unit_tests"
out=$(mktemp)
trap 'rm -f "$out"' EXIT

start=$(date +%s)
tests/run.sh asan 2>&1 | tee "$out"
rc=${PIPESTATUS[0]}
line=$(grep -E '^[0-9]+ passed, [0-9]+ failed' "$out" | tail -n 1)
if [ -z "$line" ]; then
    p=0 f=1
else
    p=${line%% passed*}; f=${line#*, }; f=${f%% failed*}
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi
fi
nrep=0
for r in "$reports"/*; do
    [ -e "$r" ] || continue
    nrep=$((nrep + 1))
    echo "== sanitizer report $r"
    head -n 80 "$r"
done
echo "sanitizer reports: $nrep; $(($(date +%s) - start)) s"
f=$((f + nrep))
echo "$p passed, $f failed"
[ "$f" -eq 0 ]
