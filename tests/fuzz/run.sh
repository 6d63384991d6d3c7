#!/usr/bin/env bash
# Runs one libFuzzer target (Makefile: make fuzz / make fuzz-smoke).
#
#   tests/fuzz/run.sh TARGET_BIN SEED_DIR WORK_DIR RUNS MAX_LEN [SEED]
#
# First replays every committed finding (tests/fuzz/regressions/), then
# fuzzes for RUNS executions on one core (no -jobs/-workers: the machine is
# shared), nice'd. WORK_DIR/corpus keeps the inputs libFuzzer finds
# interesting between runs; a crashing input lands in WORK_DIR/findings/.
# Prints one summary line: executions, time, exec/s, coverage, finding or
# not. Exits non-zero on a finding.
set -u
bin=$1 seeds=$2 work=$3 runs=$4 max_len=$5 seed=${6:-0}
name=$(basename "$bin")
cd "$(dirname "$0")/../.."
mkdir -p "$work/corpus" "$work/findings"
log="$work/$name.log"

regressions=(tests/fuzz/regressions/*)
if [ -e "${regressions[0]}" ]; then
    if ! "$bin" -runs=1 "${regressions[@]}" >"$log" 2>&1; then
        tail -n 40 "$log"
        echo "$name: a committed regression file fails again (log: $log)"
        exit 1
    fi
fi

extra=()
[ "$seed" != 0 ] && extra+=(-seed="$seed")
start=$(date +%s.%N)
nice -n 19 "$bin" -runs="$runs" -max_len="$max_len" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$work/findings/" "${extra[@]}" \
    "$work/corpus" "$seeds" >"$log" 2>&1
rc=$?
end=$(date +%s.%N)

execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
last=$(grep -E '^#[0-9]+' "$log" | tail -n 1)
cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
corp=$(sed -n 's/.* corp: \([0-9]*\).*/\1/p' <<<"$last")
secs=$(echo "$end - $start" | bc)
rate=$(echo "${execs:-0} / ($secs + 0.001)" | bc)
if [ "$rc" -eq 0 ]; then
    verdict="no finding"
else
    tail -n 60 "$log"
    verdict="FINDING (exit $rc; input in $work/findings/, log $log)"
fi
printf '%s: %s executions in %.0f s (%s exec/s), cov %s ft %s, corpus %s: %s\n' \
    "$name" "${execs:-?}" "$secs" "$rate" "${cov:-?}" "${ft:-?}" "${corp:-?}" "$verdict"
[ "$rc" -eq 0 ]
