# Helpers shared by the benchmark scripts (sourced).

# median_seconds RUNS CMD...: runs CMD once to warm the page cache, then RUNS
# times, and prints the median wall time in seconds.
median_seconds() {
    local runs=$1; shift
    "$@" >/dev/null
    local times=()
    for _ in $(seq "$runs"); do
        local t0 t1
        t0=$(date +%s.%N)
        "$@" >/dev/null
        t1=$(date +%s.%N)
        times+=("$(echo "$t1 - $t0" | bc -l)")
    done
    printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'
}
