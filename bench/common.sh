# shellcheck shell=bash
# Helpers shared by the benchmark scripts (sourced).

# median_seconds RUNS CMD...: runs CMD once to warm the page cache, then RUNS
# times, and prints the median wall time in seconds.
median_seconds() {
    local runs=$1; shift
    "$@" >/dev/null
    local times=()
    for _ in $(seq "$runs"); do
        local t0
        t0=$(date +%s.%N)
        "$@" >/dev/null
        times+=("$(seconds_since "$t0")")
    done
    printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'
}

# seconds_since T0: wall seconds elapsed since T0 (a `date +%s.%N` value).
seconds_since() {
    echo "$(date +%s.%N) - $1" | bc -l
}
