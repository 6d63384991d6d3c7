/* test_spill.c - spill files (src/spill/) and private temporary
 * directories (src/common/tmpdir.c). */
#include "harness.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "spill/spill.h"
#include "common/tmpdir.h"

/* ---- helpers ---- */

static uint64_t rng_next(uint64_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

/* A fresh empty directory under the test run's temporary directory. */
static void fresh_base(char *out, size_t len)
{
    snprintf(out, len, "%s/spill-XXXXXX", test_tmp_dir());
    if (!mkdtemp(out))
        out[0] = '\0';
}

/* Entries of dir whose name starts with prefix; the last one's path in
 * path (if not NULL). */
static int count_entries(const char *dir, const char *prefix, char *path, size_t len)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0) {
            n++;
            if (path)
                snprintf(path, len, "%s/%s", dir, e->d_name);
        }
    closedir(d);
    return n;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* One tile's expected contents. */
typedef struct ref_tile {
    size_t n, cap;
    uint64_t *gid;
    double *xyz;
    uint8_t *halo, *rec;
} ref_tile;

static void ref_push(ref_tile *r, uint64_t gid, const double *xyz, uint8_t halo,
                     const uint8_t *rec, uint32_t rs)
{
    if (r->n == r->cap) {
        r->cap = r->cap ? 2 * r->cap : 64;
        r->gid = realloc(r->gid, r->cap * 8);
        r->xyz = realloc(r->xyz, r->cap * 24);
        r->halo = realloc(r->halo, r->cap);
        r->rec = realloc(r->rec, r->cap * rs + 1);
    }
    r->gid[r->n] = gid;
    memcpy(r->xyz + 3 * r->n, xyz, 24);
    r->halo[r->n] = halo;
    memcpy(r->rec + r->n * rs, rec, rs);
    r->n++;
}

static void ref_free(ref_tile *r, int n)
{
    for (int t = 0; t < n; t++) {
        free(r[t].gid);
        free(r[t].xyz);
        free(r[t].halo);
        free(r[t].rec);
    }
    free(r);
}

/* Coordinates of point i of tile t in one of several styles, so that every
 * path of the codec is taken: LAS-like (quantised to 0.01 m, in the frame
 * of the minimum corner), float-like, random bits (NaN, infinities,
 * subnormals, -0), constants and zeros. */
static void make_xyz(int t, uint64_t i, uint64_t *s, double *xyz)
{
    int style = t % 6;
    for (int k = 0; k < 3; k++) {
        uint64_t u = rng_next(s);
        double v;
        switch (style) {
        case 0: /* LAS: X * 0.01 + offset - min, points near each other */
        case 1: {
            static const double off[3] = {639187.0, 221748.0, 323.0};
            static const double mn[3] = {633370.82, 215000.01, 88.5};
            int32_t X = (int32_t)(i * 37 % 100000) - 58000 + (int32_t)(u % 200);
            v = (X * 0.01 + off[k]) - mn[k];
            break;
        }
        case 2: /* float coordinates widened */
            v = (double)(float)((double)(u >> 11) / 9007199254740992.0 * 1000.0 - 200.0);
            break;
        case 3: /* any bit pattern, now and then */
            if (u % 7 == 0)
                memcpy(&v, &u, 8);
            else
                v = (double)(u % 100000) * 0.001;
            break;
        case 4: /* specials */ {
            static const double sp[] = {0.0, -0.0, 1e300, -1e-310, 5e-324, 1.5, -2.25};
            v = sp[u % 7];
            if (u % 11 == 0)
                v = (u & 1) ? INFINITY : NAN;
            break;
        }
        default: /* constant and zero */
            v = k == 2 ? 0.0 : 42.5;
        }
        xyz[k] = v;
    }
}

static int same_bits(const void *a, const void *b, size_t n)
{
    return n == 0 || memcmp(a, b, n) == 0;
}

/* Fills a spill of ntiles with random appends (tiles t % 7 == 3 stay
 * empty; tile 1 gets far more than one buffer), checks every tile back.
 * More than 64 tiles: more files than the spill keeps open. Returns the
 * number of failed checks. */
static int round_trip(int ntiles, int threads, int level, size_t buffer_bytes, uint32_t rs)
{
    int failures = 0, *failures_ = &failures;
    char base[512];
    fresh_base(base, sizeof base);
    CHECK(base[0]);
    enum { BATCH = 64 };
    const int NTILES = ntiles;
    wpd_spill_options opt;
    wpd_spill_default_options(&opt);
    opt.threads = threads;
    opt.level = level;
    opt.buffer_bytes = buffer_bytes;
    wpd_error err;
    wpd_spill *s = wpd_spill_create(base, NTILES, rs, &opt, &err);
    CHECK_MSG(s, "%s", err.msg);
    if (!s)
        return failures;
    ref_tile *ref = calloc(NTILES, sizeof *ref);
    uint64_t seed = 0x9e3779b97f4a7c15ull ^ (uint64_t)threads, gid = 1000;
    uint64_t g[BATCH];
    double xyz[3 * BATCH];
    uint8_t halo[BATCH], rec[BATCH * 64];
    for (int round = 0; round < 20 * NTILES + 1000; round++) {
        int t = (int)(rng_next(&seed) % NTILES);
        if (t % 7 == 3)
            t = 1;
        size_t n = 1 + rng_next(&seed) % BATCH;
        for (size_t i = 0; i < n; i++) {
            g[i] = gid += 1 + rng_next(&seed) % (t == 2 ? 100000 : 3);
            make_xyz(t, gid, &seed, xyz + 3 * i);
            halo[i] = rng_next(&seed) % 5 == 0;
            for (uint32_t b = 0; b < rs; b++)
                rec[i * rs + b] = (uint8_t)(b < rs / 2 ? rng_next(&seed) : (gid >> b));
            ref_push(&ref[t], g[i], xyz + 3 * i, halo[i], rec + i * rs, rs);
        }
        int with_halo = t % 4 != 0; /* NULL halo: all 0 */
        if (!with_halo)
            for (size_t i = 0; i < n; i++)
                ref[t].halo[ref[t].n - n + i] = 0;
        if (wpd_spill_append(s, t, g, xyz, with_halo ? halo : NULL, rec, n, &err)) {
            CHECK_MSG(0, "append: %s", err.msg);
            break;
        }
    }
    CHECK_MSG(wpd_spill_finish(s, &err) == 0, "finish: %s", err.msg);
    uint64_t total = 0;
    for (int t = 0; t < NTILES; t++) {
        CHECK(wpd_spill_count(s, t) == ref[t].n);
        total += ref[t].n;
        for (int with = 0; with < 2; with++) {
            wpd_tile_data d;
            if (wpd_spill_read(s, t, with, &d, &err)) {
                CHECK_MSG(0, "read tile %d: %s", t, err.msg);
                continue;
            }
            CHECK_MSG(d.n == ref[t].n, "tile %d: %zu points, expected %zu", t, d.n, ref[t].n);
            if (d.n == ref[t].n) {
                CHECK_MSG(same_bits(d.gid, ref[t].gid, 8 * d.n), "tile %d gids", t);
                CHECK_MSG(same_bits(d.xyz, ref[t].xyz, 24 * d.n), "tile %d xyz", t);
                CHECK_MSG(same_bits(d.halo, ref[t].halo, d.n), "tile %d halo", t);
                if (with)
                    CHECK_MSG(d.records && same_bits(d.records, ref[t].rec, d.n * rs),
                              "tile %d records", t);
            }
            if (!with)
                CHECK_MSG(d.records == NULL, "tile %d: records without asking", t);
            wpd_tile_data_free(&d);
        }
    }
    CHECK(ref[1].n > 5000);
    wpd_spill_stats st;
    wpd_spill_get_stats(s, &st);
    CHECK(st.points == total);
    CHECK(st.disk_bytes > 0 && st.raw_bytes == total * (33 + rs));
    wpd_spill_destroy(s);
    CHECK_MSG(count_entries(base, "wpd-spill-", NULL, 0) == 0, "spill directory left in %s", base);
    ref_free(ref, NTILES);
    rmdir(base);
    return failures;
}

/* ---- spill ---- */

TEST(spill_round_trip_caller_thread)
{
    *failures_ += round_trip(29, 0, -7, 4096, 34);
}

TEST(spill_round_trip_two_threads)
{
    *failures_ += round_trip(150, 2, 1, 8192, 13);
}

TEST(spill_round_trip_defaults_no_records)
{
    wpd_spill_options o;
    wpd_spill_default_options(&o);
    *failures_ += round_trip(29, o.threads, o.level, o.buffer_bytes, 0);
}

/* A finished spill of a few tiles under a fresh base; path of tile 0's
 * file in file. */
static wpd_spill *small_spill(char *base, size_t blen, char *file, size_t flen, int *failures_)
{
    fresh_base(base, blen);
    wpd_spill_options opt;
    wpd_spill_default_options(&opt);
    opt.buffer_bytes = 4096;
    wpd_error err;
    wpd_spill *s = wpd_spill_create(base, 3, 20, &opt, &err);
    CHECK_MSG(s, "%s", err.msg);
    if (!s)
        return NULL;
    uint64_t seed = 7;
    for (uint64_t i = 0; i < 3000; i++) {
        double xyz[3] = {(double)(rng_next(&seed) % 100000) * 0.01, i * 0.01, 3.0};
        uint8_t rec[20];
        for (int b = 0; b < 20; b++)
            rec[b] = (uint8_t)rng_next(&seed);
        CHECK(wpd_spill_append(s, (int)(i % 3), &i, xyz, NULL, rec, 1, &err) == 0);
    }
    CHECK_MSG(wpd_spill_finish(s, &err) == 0, "%s", err.msg);
    char dir[600];
    CHECK(count_entries(base, "wpd-spill-", dir, sizeof dir) == 1);
    snprintf(file, flen, "%s/tile-000000", dir);
    CHECK_MSG(exists(file), "no %s", file);
    return s;
}

/* Overwrites len bytes at off of path with x ^ 0x5a. */
static void flip(const char *path, off_t off, size_t len)
{
    int fd = open(path, O_RDWR);
    uint8_t buf[64];
    if (fd < 0 || len > sizeof buf || pread(fd, buf, len, off) != (ssize_t)len)
        return;
    for (size_t i = 0; i < len; i++)
        buf[i] ^= 0x5a;
    if (pwrite(fd, buf, len, off) != (ssize_t)len)
        buf[0] = 0;
    close(fd);
}

TEST(spill_corrupt_chunk_is_an_error)
{
    char base[512], file[700];
    wpd_spill *s = small_spill(base, sizeof base, file, sizeof file, failures_);
    if (!s)
        return;
    struct stat st;
    CHECK(stat(file, &st) == 0 && st.st_size > 2000);
    wpd_error err;
    wpd_tile_data d;
    /* inside the first coordinate frame, then the first header, then the
     * middle of the file */
    off_t where[3] = {40, 4, st.st_size / 2};
    for (int k = 0; k < 3; k++) {
        flip(file, where[k], 8);
        CHECK(wpd_spill_read(s, 0, 1, &d, &err) == -1);
        CHECK_MSG(err.code == WPD_E_IO && strstr(err.msg, file), "%s", err.msg);
        CHECK(d.gid == NULL && d.xyz == NULL && d.records == NULL);
        flip(file, where[k], 8); /* undo */
        CHECK_MSG(wpd_spill_read(s, 0, 1, &d, &err) == 0, "%s", err.msg);
        wpd_tile_data_free(&d);
    }
    /* truncated in the last record frame: coordinates alone still read */
    CHECK(truncate(file, st.st_size - 10) == 0);
    CHECK(wpd_spill_read(s, 0, 1, &d, &err) == -1);
    CHECK_MSG(err.code == WPD_E_IO && strstr(err.msg, "truncated"), "%s", err.msg);
    CHECK_MSG(wpd_spill_read(s, 0, 0, &d, &err) == 0 && d.n == 1000, "%s", err.msg);
    wpd_tile_data_free(&d);
    CHECK(truncate(file, st.st_size / 2) == 0);
    CHECK(wpd_spill_read(s, 0, 0, &d, &err) == -1);
    CHECK_MSG(err.code == WPD_E_IO && strstr(err.msg, "truncated"), "%s", err.msg);
    /* other tiles are unaffected */
    CHECK_MSG(wpd_spill_read(s, 1, 1, &d, &err) == 0 && d.n == 1000, "%s", err.msg);
    wpd_tile_data_free(&d);
    wpd_spill_destroy(s);
    CHECK(!exists(file));
    CHECK(count_entries(base, "", NULL, 0) == 2); /* . and .. */
    rmdir(base);
}

TEST(spill_misuse_is_an_error)
{
    char base[512], file[700];
    wpd_spill *s = small_spill(base, sizeof base, file, sizeof file, failures_);
    if (!s)
        return;
    wpd_error err;
    uint64_t g = 1;
    double xyz[3] = {0, 0, 0};
    uint8_t rec[20] = {0};
    CHECK(wpd_spill_append(s, 0, &g, xyz, NULL, rec, 1, &err) == -1);
    wpd_tile_data d;
    CHECK(wpd_spill_read(s, 3, 0, &d, &err) == -1);
    CHECK(wpd_spill_read(s, -1, 0, &d, &err) == -1);
    CHECK(wpd_spill_finish(s, &err) == 0); /* twice is fine */
    wpd_spill_destroy(s);
    wpd_spill_destroy(NULL);
    rmdir(base);
    char missing[600];
    snprintf(missing, sizeof missing, "%s/does/not/exist", test_tmp_dir());
    CHECK(wpd_spill_create(missing, 4, 10, NULL, &err) == NULL);
    CHECK_MSG(err.code == WPD_E_IO && strstr(err.msg, missing), "%s", err.msg);
}

/* ---- disk full ---- */

/* In a child limited to small files (RLIMIT_FSIZE, SIGXFSZ ignored: writes
 * fail with EFBIG), spills incompressible data until it fails. Exit status
 * 0: the failure was WPD_E_IO "disk full" naming the spill directory and
 * destroy left nothing behind. */
static int disk_full_child(const char *base, int threads)
{
    struct rlimit rl = {256 << 10, 256 << 10};
    signal(SIGXFSZ, SIG_IGN);
    if (setrlimit(RLIMIT_FSIZE, &rl))
        return 10;
    wpd_spill_options opt;
    wpd_spill_default_options(&opt);
    opt.threads = threads;
    wpd_error err;
    wpd_spill *s = wpd_spill_create(base, 2, 200, &opt, &err);
    if (!s)
        return 11;
    uint64_t seed = 99, i = 0;
    int rc = 0;
    uint8_t rec[200];
    for (; i < 100000 && rc == 0; i++) {
        double xyz[3] = {(double)rng_next(&seed), (double)rng_next(&seed), 1};
        for (int b = 0; b < 200; b++)
            rec[b] = (uint8_t)rng_next(&seed);
        rc = wpd_spill_append(s, 0, &i, xyz, NULL, rec, 1, &err);
    }
    if (rc == 0)
        rc = wpd_spill_finish(s, &err);
    if (rc == 0)
        return 12;
    if (err.code != WPD_E_IO || !strstr(err.msg, "disk full") || !strstr(err.msg, base))
        return 13;
    wpd_spill_destroy(s);
    return count_entries(base, "wpd-spill-", NULL, 0) == 0 ? 0 : 14;
}

TEST(spill_disk_full_is_reported)
{
    for (int threads = 0; threads < 2; threads++) {
        char base[512];
        fresh_base(base, sizeof base);
        pid_t pid = fork();
        if (pid == 0)
            _exit(disk_full_child(base, threads)); /* _exit: no harness cleanup */
        int status = 0;
        CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
        CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0,
                  "threads %d: child status %d (see disk_full_child)", threads, status);
        CHECK(count_entries(base, "wpd-spill-", NULL, 0) == 0);
        rmdir(base);
    }
}

/* ---- temporary directories ---- */

TEST(tmpdir_create_and_remove)
{
    char base[512], dir[1024], file[1100];
    fresh_base(base, sizeof base);
    wpd_error err;
    CHECK_MSG(wpd_tmpdir_create(base, "wpd-test", dir, sizeof dir, &err) == 0, "%s", err.msg);
    char want[600], host[WPD_HOST_TAG_MAX + 1];
    wpd_tmpdir_host(host, sizeof host);
    CHECK(host[0] != '\0' && strchr(host, '.') == NULL && strchr(host, '/') == NULL);
    snprintf(want, sizeof want, "%s/wpd-test-%s-%ld-", base, host, (long)getpid());
    CHECK_MSG(strncmp(dir, want, strlen(want)) == 0 && strlen(dir) == strlen(want) + 6, "%s",
              dir);
    struct stat st;
    CHECK(stat(dir, &st) == 0 && S_ISDIR(st.st_mode) && (st.st_mode & 0777) == 0700);
    for (int k = 0; k < 3; k++) {
        snprintf(file, sizeof file, "%s/f%d", dir, k);
        int fd = open(file, O_WRONLY | O_CREAT, 0600);
        CHECK(fd >= 0);
        close(fd);
    }
    wpd_tmpdir_remove(dir);
    CHECK(!exists(dir));
    char tiny[8];
    CHECK(wpd_tmpdir_create(base, "wpd-test", tiny, sizeof tiny, &err) == -1);
    rmdir(base);
}

static void make_dir_with_file(const char *base, const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", base, name);
    mkdir(path, 0700);
    snprintf(path, sizeof path, "%s/%s/tile-000001", base, name);
    int fd = open(path, O_WRONLY | O_CREAT, 0600);
    if (fd >= 0)
        close(fd);
}

TEST(tmpdir_sweep_removes_only_dead_runs)
{
    char base[512], name[128], path[1024];
    fresh_base(base, sizeof base);
    pid_t dead = fork();
    if (dead == 0)
        _exit(0);
    waitpid(dead, NULL, 0);
    snprintf(name, sizeof name, "wpd-spill-%ld-Ab3xZ9", (long)dead);
    make_dir_with_file(base, name);
    snprintf(name, sizeof name, "wpd-spill-%ld-Qw12er", (long)getpid());
    make_dir_with_file(base, name); /* alive: ours */
    snprintf(name, sizeof name, "wpd-spill-1-Qw12er"); /* alive: init */
    make_dir_with_file(base, name);
    snprintf(name, sizeof name, "other-%ld-Ab3xZ9", (long)dead);
    make_dir_with_file(base, name);
    snprintf(name, sizeof name, "wpd-spill-%ld-Ab3xZ", (long)dead); /* 5 letters */
    make_dir_with_file(base, name);
    snprintf(name, sizeof name, "wpd-spill-%ldx-Ab3xZ9", (long)dead);
    make_dir_with_file(base, name);
    snprintf(path, sizeof path, "%s/wpd-spill-%ld-file00", base, (long)dead); /* a file */
    close(open(path, O_WRONLY | O_CREAT, 0600));
    /* With host tags: this host's dead run goes, another host's stays (its
     * pid means nothing here), whatever '-' the tags hold. */
    char host[WPD_HOST_TAG_MAX + 1];
    wpd_tmpdir_host(host, sizeof host);
    snprintf(name, sizeof name, "wpd-spill-%s-%ld-Cd4yW0", host, (long)dead);
    make_dir_with_file(base, name);
    snprintf(name, sizeof name, "wpd-spill-%s-%ld-Cd4yW1", host, (long)getpid());
    make_dir_with_file(base, name); /* alive: ours */
    snprintf(name, sizeof name, "wpd-spill-other-node-7-%ld-Cd4yW2", (long)dead);
    make_dir_with_file(base, name);
    snprintf(name, sizeof name, "wpd-spill-%s-x-%ld-Cd4yW3", host, (long)dead);
    make_dir_with_file(base, name); /* a host whose tag starts like ours */

    CHECK(wpd_tmpdir_sweep_stale(base, "wpd-spill") == 2);
    snprintf(path, sizeof path, "%s/wpd-spill-%ld-Ab3xZ9", base, (long)dead);
    CHECK(!exists(path));
    snprintf(path, sizeof path, "%s/wpd-spill-%s-%ld-Cd4yW0", base, host, (long)dead);
    CHECK(!exists(path));
    CHECK(count_entries(base, "", NULL, 0) == 2 + 6 + 3);
    CHECK(wpd_tmpdir_sweep_stale(base, "wpd-spill") == 0);
    CHECK(wpd_tmpdir_sweep_stale("/nonexistent-wpd-dir", "wpd-spill") == 0);
}

/* In a child: a spill with files (and compression threads busy), then a
 * signal. The directory must be gone and the child killed by the signal. */
TEST(tmpdir_signal_removes_spill)
{
    static const int sigs[] = {SIGTERM, SIGINT, SIGHUP};
    for (int k = 0; k < 3; k++) {
        char base[512];
        fresh_base(base, sizeof base);
        pid_t pid = fork();
        if (pid == 0) {
            wpd_spill_options opt;
            wpd_spill_default_options(&opt);
            opt.buffer_bytes = 4096;
            opt.threads = 2;
            wpd_error err;
            wpd_spill *s = wpd_spill_create(base, 8, 16, &opt, &err);
            if (!s)
                _exit(20);
            uint8_t rec[16] = {1};
            for (uint64_t i = 0; i < 200000; i++) {
                double xyz[3] = {i * 0.5, 1, 2};
                if (wpd_spill_append(s, (int)(i % 8), &i, xyz, NULL, rec, 1, &err))
                    _exit(21);
            }
            if (count_entries(base, "wpd-spill-", NULL, 0) != 1)
                _exit(22);
            raise(sigs[k]);
            _exit(23);
        }
        int status = 0;
        CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
        CHECK_MSG(WIFSIGNALED(status) && WTERMSIG(status) == sigs[k], "signal %d: status %d",
                  sigs[k], status);
        CHECK_MSG(count_entries(base, "wpd-spill-", NULL, 0) == 0, "spill left in %s", base);
        rmdir(base);
    }
}
