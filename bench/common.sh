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

# median_seconds_pair RUNS BIN BASE ARGS...: BIN ARGS and BASE ARGS, each
# run once to warm up, then RUNS times in turn (BASE right after BIN, so
# both see the same machine); prints the two median wall times.
median_seconds_pair() {
    local runs=$1 bin=$2 base=$3; shift 3
    "$bin" "$@" >/dev/null
    "$base" "$@" >/dev/null
    local a=() b=() t0
    for _ in $(seq "$runs"); do
        t0=$(date +%s.%N); "$bin" "$@" >/dev/null; a+=("$(seconds_since "$t0")")
        t0=$(date +%s.%N); "$base" "$@" >/dev/null; b+=("$(seconds_since "$t0")")
    done
    local med='{v[NR]=$1} END {print (NR%2) ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2}'
    echo "$(printf '%s\n' "${a[@]}" | sort -g | awk "$med")" \
         "$(printf '%s\n' "${b[@]}" | sort -g | awk "$med")"
}

# seconds_since T0: wall seconds elapsed since T0 (a `date +%s.%N` value).
seconds_since() {
    echo "$(date +%s.%N) - $1" | bc -l
}
