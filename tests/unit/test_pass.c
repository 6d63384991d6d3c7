/* test_pass.c - the streaming pass (io/pass.h) and the bounded reads
 * under it: the same points, global indices and counts whatever the lanes
 * and the reading mode, on files with non-finite points across file and
 * unit boundaries. */
#include "harness.h"

#include "io/cloud.h"
#include "resample/budget.h"
#include "io/pass.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Record i of the test cloud: x = i, y = -i, z = 1, or NaN coordinates
 * for every 7th record and for a run longer than a unit (a unit whose
 * points are all dropped). */
static int dropped_record(uint64_t i)
{
    return i % 7 == 3 || (i >= 160000 && i < 240000);
}

/* Records [lo, hi) as a PLY file of float x y z, binary or ASCII. */
static int write_ply(const char *path, uint64_t lo, uint64_t hi, int ascii)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    fprintf(f, "ply\nformat %s 1.0\nelement vertex %llu\nproperty float x\n"
               "property float y\nproperty float z\nend_header\n",
            ascii ? "ascii" : "binary_little_endian", (unsigned long long)(hi - lo));
    for (uint64_t i = lo; i < hi; i++) {
        float v[3] = {(float)i, -(float)i, 1};
        if (dropped_record(i))
            v[0] = NAN;
        if (ascii)
            fprintf(f, "%.9g %.9g %.9g\n", v[0], v[1], v[2]);
        else
            fwrite(v, sizeof v, 1, f);
    }
    return fclose(f);
}

/* Two files: records [0, 100003) and [100003, 250000). */
static wpd_cloud *open_test_cloud(int ascii, wpd_error *err)
{
    char a[1024], b[1024];
    snprintf(a, sizeof a, "%s/pass_%d_a.ply", test_tmp_dir(), ascii);
    snprintf(b, sizeof b, "%s/pass_%d_b.ply", test_tmp_dir(), ascii);
    if (write_ply(a, 0, 100003, ascii) || write_ply(b, 100003, 250000, ascii))
        return NULL;
    const char *paths[2] = {a, b};
    return wpd_cloud_open(paths, 2, err);
}

/* Global index -> record, for the checks: the i-th finite record. */
static uint64_t *finite_records(uint64_t n, uint64_t *count)
{
    uint64_t *r = malloc(n * sizeof *r), k = 0;
    for (uint64_t i = 0; r && i < n; i++)
        if (!dropped_record(i))
            r[k++] = i;
    *count = k;
    return r;
}

typedef struct seen {
    const uint64_t *record;   /* [finite] gid -> record */
    uint64_t finite;
    uint64_t next_gid;        /* ordered: the next global index expected */
    int bad;                  /* a point at the wrong global index */
    uint64_t lane_points[8];
} seen;

static int check_points(seen *s, const wpd_batch *b, uint64_t gid)
{
    for (size_t i = 0; i < b->n; i++)
        if (gid + i >= s->finite || b->xyz[3 * i] != (double)s->record[gid + i])
            return 1;
    return 0;
}

static int on_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    seen *s = arg;
    s->lane_points[pb->lane] += pb->batch->n;
    if (pb->first_gid != WPD_PASS_GID_UNKNOWN && check_points(s, pb->batch, pb->first_gid))
        s->bad = 1;
    return 0;
}

static int on_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    seen *s = arg;
    if (pb->first_gid != s->next_gid || check_points(s, pb->batch, pb->first_gid))
        s->bad = 1;
    s->next_gid += pb->batch->n;
    return 0;
}

TEST(pass_ordered_gives_global_indices_and_counts_on_any_lanes)
{
    uint64_t finite;
    uint64_t *record = finite_records(250000, &finite);
    for (int ascii = 0; ascii < 2; ascii++) {
        wpd_error err = {0};
        wpd_cloud *c = open_test_cloud(ascii, &err);
        CHECK_MSG(c != NULL, "%s", err.msg);
        if (!c)
            continue;
        CHECK(wpd_cloud_can_seek(c) == !ascii);
        for (int threads = 1; threads <= 3; threads++) {
            seen s = {record, finite, 0, 0, {0}};
            wpd_pass p = {.cloud = c, .threads = threads, .lane = on_lane, .commit = on_commit,
                          .arg = &s};
            CHECK_MSG(wpd_pass_run(&p, &err) == 0, "%s", err.msg);
            CHECK_MSG(!s.bad && s.next_gid == finite, "ascii %d threads %d", ascii, threads);
            /* The cloud counts what one reading of it would. */
            CHECK(wpd_cloud_dropped(c) == 250000 - finite);
            CHECK(wpd_cloud_delivered(c, 0) + wpd_cloud_delivered(c, 1) == finite);
            uint64_t in_a = 0;
            for (uint64_t i = 0; i < 100003; i++)
                in_a += !dropped_record(i);
            CHECK(wpd_cloud_delivered(c, 0) == in_a);
        }
        wpd_cloud_close(c);
    }
    free(record);
}

TEST(pass_unordered_reads_each_point_once_and_stops_at_end)
{
    wpd_error err = {0};
    wpd_cloud *c = open_test_cloud(0, &err);
    CHECK_MSG(c != NULL, "%s", err.msg);
    if (!c)
        return;
    uint64_t finite;
    uint64_t *record = finite_records(250000, &finite);
    /* A pass over a part: units end exactly at `end` when reading in
     * parallel; the cloud's counts are left alone. */
    for (int threads = 1; threads <= 3; threads++) {
        seen s = {record, finite, 0, 0, {0}};
        wpd_cloud_rewind(c, &err);
        wpd_pass p = {.cloud = c, .threads = threads, .end = 180001, .lane = on_lane, .arg = &s};
        CHECK(wpd_pass_run(&p, &err) == 0);
        uint64_t total = 0, want = 0;
        for (int l = 0; l < threads; l++)
            total += s.lane_points[l];
        for (uint64_t i = 0; i < 180001; i++)
            want += !dropped_record(i);
        CHECK(!s.bad);
        CHECK_MSG(threads == 1 ? total >= want : total == want, "threads %d: %llu points, want %llu",
                  threads, (unsigned long long)total, (unsigned long long)want);
        CHECK(wpd_cloud_dropped(c) == 0 && wpd_cloud_delivered(c, 0) == 0);
    }
    free(record);
    wpd_cloud_close(c);
}

/* Marks every point a lane sees by its record (its x). */
static int on_mark(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    uint32_t *marks = arg;
    for (size_t i = 0; i < pb->batch->n; i++)
        __atomic_fetch_add(&marks[(uint64_t)pb->batch->xyz[3 * i]], 1, __ATOMIC_RELAXED);
    return 0;
}

/* Shares of a pass (the ranks of an MPI run): the shares together see every
 * finite point once, each share a part, in parallel and in serial reading,
 * on any number of lanes; a shared pass leaves the cloud's counts alone. */
TEST(pass_shares_see_every_point_once)
{
    enum { RECORDS = 250000, SHARES = 3 };
    for (int ascii = 0; ascii <= 1; ascii++) {
        wpd_error err = {0};
        wpd_cloud *c = open_test_cloud(ascii, &err);
        CHECK_MSG(c != NULL, "%s", err.msg);
        uint32_t *marks = calloc(RECORDS, sizeof *marks);
        for (int threads = 1; c && marks && threads <= 2; threads++) {
            memset(marks, 0, RECORDS * sizeof *marks);
            for (int k = 0; k < SHARES; k++) {
                uint64_t before = 0;
                for (int r = 0; r < RECORDS; r++)
                    before += marks[r];
                wpd_cloud_rewind(c, &err);
                wpd_pass p = {.cloud = c, .threads = threads, .lane = on_mark, .arg = marks,
                              .share = k, .shares = SHARES};
                CHECK(wpd_pass_run(&p, &err) == 0);
                uint64_t after = 0;
                for (int r = 0; r < RECORDS; r++)
                    after += marks[r];
                CHECK_MSG(after > before && after - before < RECORDS / 2,
                          "ascii %d, %d lanes, share %d: %llu points", ascii, threads, k,
                          (unsigned long long)(after - before));
                CHECK(wpd_cloud_dropped(c) == 0 && wpd_cloud_delivered(c, 0) == 0);
            }
            int wrong = 0;
            for (uint64_t r = 0; r < RECORDS; r++)
                wrong += marks[r] != (dropped_record(r) ? 0u : 1u);
            CHECK_MSG(wrong == 0, "ascii %d, %d lanes: %d records not seen exactly once", ascii,
                      threads, wrong);
        }
        free(marks);
        wpd_cloud_close(c);
    }
}

TEST(cloud_stretch_reads_stop_at_the_stretch_and_keep_counts)
{
    wpd_error err = {0};
    wpd_cloud *c = open_test_cloud(0, &err);
    CHECK_MSG(c != NULL, "%s", err.msg);
    if (!c)
        return;
    wpd_batch b;
    CHECK(wpd_batch_init(&b, WPD_BATCH_POINTS, 12) == 0);
    /* Records 7 .. 16: all but 10 (10 % 7 == 3) are finite. */
    CHECK(wpd_cloud_seek_stretch(c, 7, 10, &err) == 0);
    long got = wpd_cloud_read(c, &b, NULL, &err);
    CHECK(got == 9 && b.xyz[0] == 7 && b.xyz[3 * 8] == 16);
    CHECK(wpd_cloud_read(c, &b, NULL, &err) == 0);
    /* A stretch past the file's end stops at it, not in the next file. */
    CHECK(wpd_cloud_seek_stretch(c, 100000, 65536, &err) == 0);
    got = wpd_cloud_read(c, &b, NULL, &err);
    CHECK(got == 3 && b.xyz[3 * 2] == 100002);
    CHECK(wpd_cloud_read(c, &b, NULL, &err) == 0);
    /* A stretch of dropped points only: nothing, and no run into the next. */
    CHECK(wpd_cloud_seek_stretch(c, 170000, 65536, &err) == 0);
    CHECK(wpd_cloud_read(c, &b, NULL, &err) == 0);
    CHECK(wpd_cloud_dropped(c) == 1 + 65536);
    CHECK_MSG(wpd_cloud_delivered(c, 0) == 12 && wpd_cloud_delivered(c, 1) == 0, "%llu %llu",
              (unsigned long long)wpd_cloud_delivered(c, 0),
              (unsigned long long)wpd_cloud_delivered(c, 1));
    wpd_batch_free(&b);
    wpd_cloud_close(c);
}

/* ---- passes from a unit (the ranks' shares of the tile and records
 * passes) ---- */

typedef struct unit_count {
    uint64_t *points;         /* [units] */
    uint64_t units;
    int bad;                  /* a batch without its unit */
} unit_count;

static int count_units(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    unit_count *u = arg;
    if (pb->unit >= u->units)
        u->bad = 1;
    else
        __atomic_add_fetch(&u->points[pb->unit], pb->batch->n, __ATOMIC_RELAXED);
    return 0;
}

typedef struct from_unit {
    seen s;
    uint64_t stop_gid;        /* the commit that reaches it asks for no more */
    int after_stop;           /* commits after that one */
    int stopped;
} from_unit;

static int commit_until(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    from_unit *f = arg;
    if (f->stopped) {
        f->after_stop++;
        return 0;
    }
    on_commit(&f->s, pb, err);
    if (f->s.next_gid < f->stop_gid)
        return 0;
    f->stopped = 1;
    return 1;
}

TEST(pass_from_a_unit_gives_its_global_indices_and_stops)
{
    uint64_t finite;
    uint64_t *record = finite_records(250000, &finite);
    wpd_error err = {0};
    wpd_cloud *c = open_test_cloud(0, &err);
    CHECK_MSG(c != NULL, "%s", err.msg);
    unit_count u = {0};
    CHECK(c && wpd_pass_units(c, &u.units, &err) == 0 && u.units > 4);
    u.points = calloc(u.units ? u.units : 1, sizeof *u.points);
    uint64_t dropped = 0;
    wpd_pass count = {.cloud = c, .threads = 2, .lane = count_units, .arg = &u,
                      .dropped = &dropped};
    CHECK(u.points && wpd_pass_run(&count, &err) == 0 && !u.bad);
    CHECK(dropped == 250000 - finite);
    uint64_t sum = 0;
    for (uint64_t k = 0; k < u.units; k++)
        sum += u.points[k];
    CHECK(sum == finite);
    /* From the second unit, the one after the file boundary, and the last:
     * the global indices of a whole pass, and no commit after the one
     * that says enough. */
    uint64_t starts[3] = {1, u.units / 2, u.units - 1};
    for (int k = 0; k < 3 && sum == finite; k++) {
        uint64_t first_gid = 0;
        for (uint64_t j = 0; j < starts[k]; j++)
            first_gid += u.points[j];
        for (int threads = 1; threads <= 3; threads += 2) {
            from_unit f = {{record, finite, first_gid, 0, {0}}, first_gid + 70000, 0, 0};
            wpd_pass p = {.cloud = c, .threads = threads, .commit = commit_until, .arg = &f,
                          .first_unit = starts[k], .first_gid = first_gid};
            CHECK_MSG(wpd_cloud_rewind(c, &err) == 0 && wpd_pass_run(&p, &err) == 0, "%s",
                      err.msg);
            CHECK_MSG(!f.s.bad && f.after_stop == 0, "unit %llu threads %d",
                      (unsigned long long)starts[k], threads);
            CHECK(f.s.next_gid >= (f.stop_gid < finite ? f.stop_gid : finite));
        }
    }
    free(u.points);
    wpd_cloud_close(c);
    free(record);
}
