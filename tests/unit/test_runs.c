/* test_runs.c - sorted runs of samples (spill/runs.h) and their k-way
 * merge (spill/run_merge.h), against a sort of the same samples. */
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "harness.h"
#include "spill/run_merge.h"
#include "spill/runs.h"

/* Deterministic coordinates and label of a sample: every field depends on
 * the gid, so a sample moved to another gid is seen. */
static void sample_of(uint64_t gid, double *xyz, uint8_t *edge)
{
    xyz[0] = (double)(gid % 1000) * 0.01 + 1e5;
    xyz[1] = (double)(gid / 7) * 0.25;
    xyz[2] = gid % 5 ? (double)gid * 1e-3 : -(double)gid / 3.0; /* off any grid */
    *edge = gid % 3 == 0;
}

static uint64_t rng_next(uint64_t *s)
{
    *s ^= *s << 13, *s ^= *s >> 7, *s ^= *s << 17;
    return *s;
}

/* Spreads gids 0, step, 2 step, ... over nruns runs: run r gets a share
 * by weight[r] (random choice), each run ascending. Writes them into rs
 * (put or append in pieces). Returns the total. */
static uint64_t fill_runs(wpd_runs *rs, int nruns, const unsigned *weight, uint64_t total,
                          uint64_t step, uint64_t seed)
{
    unsigned wsum = 0;
    for (int r = 0; r < nruns; r++)
        wsum += weight[r];
    uint64_t **gid = calloc((size_t)nruns, sizeof *gid);
    size_t *n = calloc((size_t)nruns, sizeof *n);
    for (int r = 0; r < nruns; r++)
        gid[r] = malloc((total ? total : 1) * sizeof **gid);
    for (uint64_t i = 0; i < total; i++) {
        unsigned pick = wsum ? (unsigned)(rng_next(&seed) % wsum) : 0;
        int r = 0;
        while (r < nruns - 1 && pick >= weight[r])
            pick -= weight[r++];
        gid[r][n[r]++] = i * step + 3;
    }
    wpd_error err;
    wpd_runs_reserve(rs, nruns, &err);
    for (int r = 0; r < nruns; r++) {
        double *xyz = malloc((n[r] ? n[r] : 1) * 3 * sizeof *xyz);
        uint8_t *edge = malloc(n[r] ? n[r] : 1);
        for (size_t k = 0; k < n[r]; k++)
            sample_of(gid[r][k], xyz + 3 * k, edge + k);
        if (r % 2) { /* half of them appended in two pieces */
            size_t half = n[r] / 2;
            wpd_sample_view a = {half, gid[r], xyz, edge};
            wpd_sample_view b = {n[r] - half, gid[r] + half, xyz + 3 * half, edge + half};
            wpd_runs_append(rs, r, &a, &err);
            wpd_runs_append(rs, r, &b, &err);
            free(gid[r]), free(xyz), free(edge);
        } else {
            wpd_runs_put(rs, r, gid[r], xyz, edge, n[r], &err);
        }
    }
    free(gid);
    free(n);
    return total;
}

/* The smallest budget giving a fan-in of at least f. */
static size_t budget_for(size_t chunk, int f)
{
    size_t lo = 0, hi = (size_t)1 << 40;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (wpd_run_merge_fan_in(chunk, mid) >= f)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

static int nonempty_runs(const wpd_runs *rs)
{
    int k = 0;
    for (int id = 0; id < wpd_runs_count(rs); id++)
        k += wpd_runs_length(rs, id) > 0;
    return k;
}

/* Merges rs within budget, checking every sample against the sorted
 * sequence 3, 3 + step, ...: count, order, coordinates, labels. Handing
 * out is cut at gid bounds every `cut` gids. Returns the merge levels
 * run, or -1 on a mismatch. */
static int merge_and_check(wpd_runs *rs, size_t budget, uint64_t total, uint64_t step,
                           uint64_t cut, int *failures_)
{
    wpd_error err = {0};
    wpd_run_merge *m;
    int open_rc = wpd_run_merge_open(rs, budget, &m, &err);
    CHECK_MSG(open_rc == 0, "%s", err.msg);
    if (open_rc)
        return -1;
    int fan_in = wpd_runs_in_files(rs) ? wpd_run_merge_fan_in(wpd_runs_chunk_points(rs), budget)
                                       : 1 << 30;
    CHECK_MSG(nonempty_runs(rs) <= fan_in, "%d runs left, fan-in %d", nonempty_runs(rs), fan_in);
    uint64_t i = 0, bad = 0;
    for (uint64_t end = cut;; end += cut) {
        wpd_sample_view v;
        if (wpd_run_merge_next(m, end, &v, &err)) {
            CHECK_MSG(0, "%s", err.msg);
            break;
        }
        if (v.n == 0 && wpd_run_merge_left(m) == 0)
            break;
        for (size_t k = 0; k < v.n; k++, i++) {
            double xyz[3];
            uint8_t edge;
            uint64_t want = i * step + 3;
            sample_of(want, xyz, &edge);
            bad += v.gid[k] != want || v.gid[k] >= end || memcmp(xyz, v.xyz + 3 * k, sizeof xyz) ||
                   (wpd_runs_with_edge(rs) ? v.edge[k] != edge : v.edge != NULL);
        }
        if (v.n == wpd_runs_chunk_points(rs))
            end -= cut; /* the chunk was full: the same bound again */
    }
    CHECK_MSG(i == total && bad == 0, "%llu of %llu samples, %llu wrong",
              (unsigned long long)i, (unsigned long long)total, (unsigned long long)bad);
    int levels = wpd_run_merge_levels(m);
    wpd_run_merge_close(m);
    return i == total && bad == 0 ? levels : -1;
}

static wpd_runs *open_set(int in_files, int with_edge, size_t chunk)
{
    wpd_runs_options o = {in_files ? test_tmp_dir() : NULL, with_edge, chunk, 0};
    wpd_runs *rs = NULL;
    wpd_error err;
    if (wpd_runs_open(&o, &rs, &err))
        fprintf(stderr, "  %s\n", err.msg);
    return rs;
}

TEST(runs_many_small_runs_tiny_fan_in)
{
    for (int with_edge = 0; with_edge < 2; with_edge++) {
        wpd_runs *rs = open_set(1, with_edge, 16);
        unsigned w[1000];
        for (int r = 0; r < 1000; r++)
            w[r] = 1;
        uint64_t total = fill_runs(rs, 1000, w, 20000, 3, 7 + with_edge);
        int levels = merge_and_check(rs, budget_for(16, 3), total, 3, 1000, failures_);
        CHECK_MSG(levels > 100, "%d merge levels for 1000 runs at fan-in 3", levels);
        wpd_runs_close(rs);
    }
}

TEST(runs_equal_skewed_and_empty_runs)
{
    unsigned equal[64], skewed[64], holes[64];
    for (int r = 0; r < 64; r++) {
        equal[r] = 1;
        skewed[r] = r == 5 ? 4000 : r % 3 ? 1 : 20; /* one run holds most */
        holes[r] = r % 4 ? 0 : 1;                   /* three quarters empty */
    }
    const unsigned *cases[] = {equal, skewed, holes};
    for (int c = 0; c < 3; c++)
        for (int in_files = 0; in_files < 2; in_files++) {
            wpd_runs *rs = open_set(in_files, 1, 100);
            uint64_t total = fill_runs(rs, 64, cases[c], 30000, 1 + (uint64_t)c * 1000, 11);
            int levels = merge_and_check(rs, budget_for(100, 4), total, 1 + (uint64_t)c * 1000,
                                         5000, failures_);
            CHECK_MSG(in_files ? levels > 0 : levels == 0, "case %d, files %d: %d levels", c,
                      in_files, levels);
            wpd_runs_close(rs);
        }
}

TEST(runs_no_samples_at_all)
{
    for (int in_files = 0; in_files < 2; in_files++) {
        wpd_runs *rs = open_set(in_files, 0, 8);
        unsigned w[5] = {1, 1, 1, 1, 1};
        fill_runs(rs, 5, w, 0, 1, 3);
        CHECK(merge_and_check(rs, budget_for(8, 2), 0, 1, 10, failures_) == 0);
        wpd_runs_close(rs);
        wpd_runs *none = open_set(in_files, 1, 8);
        CHECK(merge_and_check(none, 0, 0, 1, 10, failures_) == 0);
        wpd_runs_close(none);
    }
}

TEST(runs_read_whole_replace_and_clear)
{
    wpd_runs *rs = open_set(1, 1, 10);
    unsigned w[3] = {1, 2, 3};
    fill_runs(rs, 3, w, 1000, 2, 5);
    uint64_t *gid;
    double *xyz;
    uint8_t *edge;
    size_t n;
    wpd_error err;
    CHECK(wpd_runs_read(rs, 2, &gid, &xyz, &edge, &n, &err) == 0);
    CHECK(n == wpd_runs_length(rs, 2) && n > 0);
    size_t bad = 0;
    for (size_t k = 0; k < n; k++) {
        double want[3];
        uint8_t e;
        sample_of(gid[k], want, &e);
        bad += memcmp(want, xyz + 3 * k, sizeof want) || e != edge[k] ||
               (k && gid[k] <= gid[k - 1]);
    }
    CHECK_MSG(bad == 0, "%zu samples read back wrong", bad);
    /* replaced by its first half, then cleared */
    CHECK(wpd_runs_put(rs, 2, gid, xyz, edge, n / 2, &err) == 0);
    CHECK(wpd_runs_length(rs, 2) == n / 2);
    CHECK(wpd_runs_disk_bytes(rs) > 0 && wpd_runs_memory_bytes(rs) < 4096);
    wpd_runs_clear(rs, 2);
    CHECK(wpd_runs_length(rs, 2) == 0);
    wpd_runs_close(rs);
}

TEST(runs_refuse_samples_out_of_order)
{
    for (int in_files = 0; in_files < 2; in_files++) {
        wpd_runs *rs = open_set(in_files, 0, 4);
        wpd_error err;
        int id;
        uint64_t a[3] = {5, 9, 12}, b[2] = {12, 13}, c[2] = {20, 19};
        double xyz[9] = {0};
        wpd_sample_view va = {3, a, xyz, NULL}, vb = {2, b, xyz, NULL}, vc = {2, c, xyz, NULL};
        CHECK(wpd_runs_add(rs, &id, &err) == 0);
        CHECK(wpd_runs_append(rs, id, &va, &err) == 0);
        CHECK(wpd_runs_append(rs, id, &vb, &err) == -1 && err.code == WPD_E_INPUT);
        CHECK(wpd_runs_append(rs, id, &vc, &err) == -1);
        CHECK(wpd_runs_length(rs, id) == 3);
        wpd_runs_close(rs);
    }
}

TEST(runs_damaged_file_is_an_error_and_close_removes_everything)
{
    wpd_runs *rs = open_set(1, 0, 64);
    unsigned w[2] = {1, 1};
    fill_runs(rs, 2, w, 500, 1, 9);
    char dir[1024], path[1200];
    CHECK(test_tmp_entries("wpd-runs-", dir, sizeof dir) == 1);
    snprintf(path, sizeof path, "%s/run-%06d", dir, 0);
    int fd = open(path, O_WRONLY);
    CHECK(fd >= 0 && pwrite(fd, "\xff\xff\xff\xff", 4, 40) == 4);
    if (fd >= 0)
        close(fd);
    uint64_t *gid;
    double *xyz;
    uint8_t *edge;
    size_t n;
    wpd_error err = {0};
    CHECK(wpd_runs_read(rs, 0, &gid, &xyz, &edge, &n, &err) == -1 && err.code == WPD_E_INPUT);
    CHECK_MSG(strstr(err.msg, "run-000000") != NULL, "%s", err.msg);
    wpd_runs_close(rs);
    struct stat st;
    CHECK_MSG(stat(dir, &st) != 0, "%s left behind", dir);
    CHECK(test_tmp_entries("wpd-runs-", dir, sizeof dir) == 0);
}

TEST(runs_fan_in_grows_with_the_budget)
{
    int small = wpd_run_merge_fan_in(8192, 4 << 20), large = wpd_run_merge_fan_in(8192, 64 << 20);
    CHECK(wpd_run_merge_fan_in(8192, 0) == 2);
    CHECK_MSG(small >= 2 && large > 8 * small / 2 && large < 300, "%d %d", small, large);
    CHECK(wpd_run_merge_fan_in(8192, WPD_RUN_MERGE_BUDGET) >= 40);
}
