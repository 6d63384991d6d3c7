#!/usr/bin/env bash
# Runs one tier of the tests (docs/testing.md): the C unit tests, then the
# end-to-end tests under pytest against the built ./wpd (or $WPD_BIN).
#
#   tests/run.sh [fast|full|asan] [PYTEST ARGS...]
#
#   fast  (make test)       every e2e test not marked slow
#   full  (make test-full)  every e2e test
#   asan  (make test-asan)  the fast tier without the quality and peak-memory
#                           checks
#
# The e2e tests not marked serial run on $WPD_TEST_JOBS pytest workers
# (default: the number of cores), then the serial ones one at a time.
# Prints the slowest tests, the number skipped, and one closing line
# "N passed, N failed"; exits non-zero on any failure.
set -u
cd "$(dirname "$0")/.."
tier=${1:-fast}
shift $(($# > 0 ? 1 : 0))
case $tier in
    fast) select="not slow" ;;
    full) select="" ;;
    asan) select="not slow and not quality and not rss" ;;
    *) echo "tests/run.sh: unknown tier '$tier' (fast, full or asan)" >&2; exit 1 ;;
esac
jobs=${WPD_TEST_JOBS:-$(nproc)}
log=$(mktemp -d)
trap 'rm -rf "$log"' EXIT

passed=0 failed=0 skipped=0
add() {  # passed failed skipped
    passed=$((passed + $1)); failed=$((failed + $2)); skipped=$((skipped + $3))
}

echo "== unit"
"${WPD_UNIT_TESTS:-build/unit_tests}" 2>&1 | tee "$log/unit.out"
rc=${PIPESTATUS[0]}
line=$(grep -E '^[0-9]+ passed, [0-9]+ failed' "$log/unit.out" | tail -n 1)
if [ -z "$line" ]; then
    echo "unit tests printed no summary (exit $rc)"; add 0 1 0
else
    p=${line%% passed*}; f=${line#*, }; f=${f%% failed*}
    [ "$rc" -ne 0 ] && [ "$f" -eq 0 ] && f=1
    add "$p" "$f" 0
fi

# One pytest run: name, marker expression, extra pytest options.
e2e() {
    local name=$1 expr=$2
    shift 2
    echo "== e2e ($name)"
    (cd tests/e2e && /usr/bin/python3 -m pytest -q ${expr:+-m "$expr"} \
        --junitxml="$log/$name.xml" --durations=10 "$@")
    local rc=$?
    # 5: nothing selected (a tier without serial tests, or a -k that
    # leaves none); 0/1: ran; anything else: pytest itself failed.
    if [ "$rc" -eq 5 ]; then return; fi
    if [ ! -s "$log/$name.xml" ]; then
        echo "pytest ($name) exited $rc without a report"; add 0 1 0; return
    fi
    read -r p f s < <(/usr/bin/python3 - "$log/$name.xml" <<'EOF'
import sys, xml.etree.ElementTree as ET
root = ET.parse(sys.argv[1]).getroot()
suites = [root] if root.tag == "testsuite" else list(root)
t = sum(int(s.get("tests", 0)) for s in suites)
f = sum(int(s.get("failures", 0)) + int(s.get("errors", 0)) for s in suites)
s = sum(int(s.get("skipped", 0)) for s in suites)
print(t - f - s, f, s)
EOF
)
    [ "$rc" -ne 0 ] && [ "$f" -eq 0 ] && f=1
    add "$p" "$f" "$s"
}

both=${select:+$select and }
if [ "$jobs" -gt 1 ]; then
    e2e parallel "${both}not serial" -n "$jobs" "$@"
    e2e serial "${both}serial" "$@"
else
    e2e all "$select" "$@"
fi

echo "skipped: $skipped"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
