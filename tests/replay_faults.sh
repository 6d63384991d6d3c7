#!/usr/bin/env bash
# Shows that the fast tier's fault tests replay (docs/testing.md): runs
# tests/e2e/test_faults.py and test_faults_commands.py (not the slow ones)
# twice with the same WPD_FAULT_SEED, each run recording every faulted
# command's exit code, standard error and the files it left
# (WPD_FAULT_RECORD), and compares the two records.
#
#   tests/replay_faults.sh [SEED]
#
# Prints the number of outcomes compared and exits non-zero when the runs
# differ (the differing lines are shown) or a test failed.
set -u
cd "$(dirname "$0")/.."
seed=${1:-$RANDOM}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for k in 1 2; do
    echo "== run $k of 2, WPD_FAULT_SEED=$seed"
    (cd tests/e2e && WPD_FAULT_SEED=$seed WPD_FAULT_RECORD="$dir/run$k.jsonl" \
        /usr/bin/python3 -m pytest -q -m "not slow" test_faults.py test_faults_commands.py) ||
        { echo "replay: the fault tests failed in run $k"; exit 1; }
done
n1=$(wc -l < "$dir/run1.jsonl") n2=$(wc -l < "$dir/run2.jsonl")
if cmp -s "$dir/run1.jsonl" "$dir/run2.jsonl"; then
    echo "replay: $n1 faulted runs, the same exit code, standard error and files left in both"
    exit 0
fi
echo "replay: the runs differ ($n1 and $n2 outcomes):"
diff "$dir/run1.jsonl" "$dir/run2.jsonl" | head -n 40
exit 1
