/* test_las.c - the LAS reader and writer through the public API: real files
 * from ../shared/data (skipped when absent), round trips, and synthetic
 * malformed files built in memory. */
#include "harness.h"
#include "las_files.h"

#include "common/version.h"
#include "io/reader.h"
#include "io/writer.h"

#include <dirent.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* ------------------------------------------------------------ helpers */

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

/* One row of a MANIFEST.tsv: file name, point count, notes. */
typedef struct manifest_row {
    char file[256];
    long long point_count;
    char notes[4096];
} manifest_row;

/* Calls fn for every data row of dir/MANIFEST.tsv. Returns rows seen. */
static int for_each_manifest_row(const char *dir, void (*fn)(const char *dir,
                                                            const manifest_row *row, void *ctx),
                                 void *ctx)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/MANIFEST.tsv", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char *line = NULL;
    size_t cap = 0;
    int rows = 0;
    for (int lineno = 0; getline(&line, &cap, f) > 0; lineno++) {
        if (lineno == 0)
            continue; /* column names */
        line[strcspn(line, "\r\n")] = '\0';
        char *col[9] = {0};
        char *p = line;
        for (int c = 0; c < 9 && p; c++) {
            col[c] = p;
            p = strchr(p, '\t');
            if (p)
                *p++ = '\0';
        }
        if (!col[7])
            continue;
        manifest_row row;
        snprintf(row.file, sizeof row.file, "%s", col[0]);
        row.point_count = col[6][0] ? atoll(col[6]) : -1;
        snprintf(row.notes, sizeof row.notes, "%s", col[7]);
        fn(dir, &row, ctx);
        rows++;
    }
    free(line);
    fclose(f);
    return rows;
}

/* The six "bbox=[a..b, c..d, e..f]" numbers of a manifest note as printed
 * (min x, max x, min y, max y, min z, max z). Returns 0, or -1 if absent. */
static int manifest_bbox(const char *notes, char out[6][64])
{
    const char *p = strstr(notes, "bbox=[");
    if (!p)
        return -1;
    p += 6;
    for (int i = 0; i < 6; i++) {
        char *end;
        strtod(p, &end);
        if (end == p || end - p >= 64)
            return -1;
        memcpy(out[i], p, (size_t)(end - p));
        out[i][end - p] = '\0';
        p = end;
        p += (i % 2 == 0) ? 2 : 2; /* ".." or ", " */
    }
    return 0;
}

/* ------------------------------------------------------------ real files */

typedef struct manifest_ctx {
    int *failures_;
    int files;
} manifest_ctx;

static void check_manifest_file(const char *dir, const manifest_row *row, void *vctx)
{
    manifest_ctx *ctx = vctx;
    int *failures_ = ctx->failures_;
    if (!ends_with(row->file, ".las"))
        return;
    char path[1024];
    snprintf(path, sizeof path, "%.600s/%.255s", dir, row->file);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r != NULL, "%s: %s", path, err.msg);
    if (!r)
        return;
    ctx->files++;
    const wpd_header *h = wpd_reader_header(r);
    CHECK_MSG(h->format == WPD_FMT_LAS, "%s", path);
    CHECK_MSG((long long)h->point_count == row->point_count, "%s: count %llu, manifest %lld",
              path, (unsigned long long)h->point_count, row->point_count);
    char want[6][64];
    if (manifest_bbox(row->notes, want) == 0) {
        const double have[6] = {h->las.min[0], h->las.max[0], h->las.min[1],
                                h->las.max[1], h->las.min[2], h->las.max[2]};
        for (int i = 0; i < 6; i++) {
            char got[64];
            snprintf(got, sizeof got, "%.3f", have[i]);
            CHECK_MSG(!strcmp(got, want[i]), "%s: bound %d is %s, manifest %s", path, i, got,
                      want[i]);
        }
    } else {
        CHECK_MSG(0, "%s: no bbox in the manifest notes", path);
    }
    cf_cloud p;
    int rc = cf_read_all(r, &p, 1000, &err);
    CHECK_MSG(rc == 0, "%s: %s", path, err.msg);
    CHECK_MSG(p.n == h->point_count, "%s: read %llu of %llu", path, (unsigned long long)p.n,
              (unsigned long long)h->point_count);
    CHECK(wpd_reader_dropped(r) == 0);
    cf_cloud_free(&p);
    wpd_reader_close(r);
}

TEST(las_manifest_files_open_and_match)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char dir[1024];
    manifest_ctx ctx = {failures_, 0};
    snprintf(dir, sizeof dir, "%s/las", data);
    for_each_manifest_row(dir, check_manifest_file, &ctx);
    CHECK_MSG(ctx.files >= 40, "only %d LAS files in las/", ctx.files);
    snprintf(dir, sizeof dir, "%s/scans", data);
    for_each_manifest_row(dir, check_manifest_file, &ctx);
    CHECK_MSG(ctx.files >= 45, "only %d LAS files in las/ and scans/", ctx.files);
}

/* LAS files named in dir's MANIFEST.tsv (first column). */
static int manifest_las_files(const char *dir)
{
    char path[1024];
    snprintf(path, sizeof path, "%.1000s/MANIFEST.tsv", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[8192];
    int n = 0;
    while (fgets(line, sizeof line, f)) {
        char *tab = strchr(line, '\t');
        if (!tab)
            continue;
        *tab = 0;
        if (ends_with(line, ".las") || ends_with(line, ".laz"))
            n++;
    }
    fclose(f);
    return n;
}

/* A refused file's error: one line, starting with the file's path. */
static void check_one_line_error(int *failures_, const char *path, const wpd_error *err)
{
    CHECK_MSG(lt_starts_with(err->msg, path), "%s: message \"%s\"", path, err->msg);
    CHECK_MSG(!strchr(err->msg, '\n'), "%s: multi-line message", path);
}

TEST(las_bad_files_fail_with_path)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/bad", data);
    DIR *d = opendir(dir);
    if (!d)
        return;
    int files = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!ends_with(e->d_name, ".las") && !ends_with(e->d_name, ".laz"))
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%.600s/%.400s", dir, e->d_name);
        wpd_error err = lt_open_and_read(path);
        files++;
        CHECK_MSG(err.code != WPD_OK, "%s: accepted", path);
        check_one_line_error(failures_, path, &err);
        const char *expect = NULL;
        if (!strcmp(e->d_name, "pdal_bad_vlr_count.las"))
            expect = "VLR 3 of 3";
        else if (!strcmp(e->d_name, "pdal_garbage_nVariableLength.las"))
            expect = "VLR 1 of 1069128089";
        else if (!strcmp(e->d_name, "pdal_1.2-with-color-clipped.las"))
            expect = "point count 1065 needs 36210 bytes";
        if (expect)
            CHECK_MSG(strstr(err.msg, expect), "%s: \"%s\" lacks \"%s\"", path, err.msg, expect);
    }
    closedir(d);
    /* Every LAS file the manifest lists was tried (bad/ held two LAZ files
     * once; they moved to laz/). */
    CHECK(files >= 1);
    CHECK_MSG(files == manifest_las_files(dir), "%d LAS files in %s, manifest lists %d", files,
              dir, manifest_las_files(dir));
}

/* The .laz files of laz/ are read (point formats 0-5) or refused with one
 * line (6-10, LASzip 1.x, waveforms) in test_laz.c. */

/* ------------------------------------------------------------ round trip */

static int vlrs_equal(const wpd_vlr *a, const wpd_vlr *b, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        if (strcmp(a[i].user_id, b[i].user_id) || a[i].record_id != b[i].record_id ||
            a[i].length != b[i].length || strcmp(a[i].description, b[i].description) ||
            (a[i].length && memcmp(a[i].data, b[i].data, a[i].length)))
            return 0;
    return 1;
}

static void check_round_trip(const char *dir, const manifest_row *row, void *vctx)
{
    manifest_ctx *ctx = vctx;
    int *failures_ = ctx->failures_;
    char path[1024], out[1024];
    snprintf(path, sizeof path, "%.600s/%.255s", dir, row->file);
    struct stat st;
    if (!ends_with(row->file, ".las") || stat(path, &st) || st.st_size > 5000000)
        return;
    snprintf(out, sizeof out, "%.600s/rt_%.255s", test_tmp_dir(), row->file);
    wpd_error err = {0};
    wpd_reader *a = wpd_reader_open(path, &err);
    CHECK_MSG(a != NULL, "%s: %s", path, err.msg);
    if (!a)
        return;
    cf_cloud pa = {0}, pb = {0};
    const wpd_header *ha = wpd_reader_header(a);
    int ok = cf_read_all(a, &pa, 777, &err) == 0;
    CHECK_MSG(ok, "%s: %s", path, err.msg);
    ok = ok && lt_write_points(out, ha, &pa, 500, &err) == 0;
    CHECK_MSG(ok, "%s: %s", out, err.msg);
    wpd_reader *b = ok ? wpd_reader_open(out, &err) : NULL;
    CHECK_MSG(!ok || b, "%s: %s", out, err.msg);
    if (b) {
        ctx->files++;
        const wpd_header *hb = wpd_reader_header(b);
        CHECK_MSG(cf_read_all(b, &pb, 1 << 16, &err) == 0, "%s: %s", out, err.msg);
        CHECK_MSG(hb->point_count == ha->point_count && pb.n == pa.n, "%s", path);
        CHECK_MSG(pb.n == pa.n && (pa.n == 0 || !memcmp(pa.records, pb.records, pa.n * pa.record_size)),
                  "%s: point records differ", path);
        CHECK_MSG(hb->las.nvlr == ha->las.nvlr &&
                      vlrs_equal(ha->las.vlrs, hb->las.vlrs, ha->las.nvlr),
                  "%s: VLRs differ", path);
        CHECK_MSG(hb->las.nevlr == ha->las.nevlr &&
                      vlrs_equal(ha->las.evlrs, hb->las.evlrs, ha->las.nevlr),
                  "%s: EVLRs differ (%u vs %u)", path, ha->las.nevlr, hb->las.nevlr);
        CHECK_MSG(hb->las.pdrf == ha->las.pdrf && hb->las.record_length == ha->las.record_length &&
                      hb->las.version_minor == ha->las.version_minor &&
                      hb->las.header_tail_len == ha->las.header_tail_len &&
                      hb->las.creation_year == ha->las.creation_year &&
                      !memcmp(hb->las.guid, ha->las.guid, 16) &&
                      !strcmp(hb->las.system_id, ha->las.system_id) &&
                      !strcmp(hb->las.software, WPD_SOFTWARE),
                  "%s: header facts differ", path);
        /* Output bounds are those of the records written. */
        for (int k = 0; k < 3 && pb.n; k++) {
            double lo = INFINITY, hi = -INFINITY;
            for (uint64_t i = 0; i < pb.n; i++) {
                lo = fmin(lo, pb.xyz[3 * i + k]);
                hi = fmax(hi, pb.xyz[3 * i + k]);
            }
            CHECK_MSG(hb->las.min[k] == lo && hb->las.max[k] == hi, "%s: bounds axis %d", path,
                      k);
        }
        cf_cloud_free(&pb);
        wpd_reader_close(b);
    }
    cf_cloud_free(&pa);
    wpd_reader_close(a);
    unlink(out);
}

TEST(las_round_trip_keeps_records_and_vlrs)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char dir[1024];
    manifest_ctx ctx = {failures_, 0};
    snprintf(dir, sizeof dir, "%s/las", data);
    for_each_manifest_row(dir, check_round_trip, &ctx);
    snprintf(dir, sizeof dir, "%s/scans", data);
    for_each_manifest_row(dir, check_round_trip, &ctx);
    CHECK_MSG(ctx.files >= 40, "only %d round trips", ctx.files);
}

/* ------------------------------------------------------------ specific files */

static wpd_reader *open_data(const char *rel, int *failures_)
{
    const char *data = test_data_dir();
    if (!data)
        return NULL;
    char path[1024];
    snprintf(path, sizeof path, "%.600s/%.255s", data, rel);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r != NULL, "%s: %s", path, err.msg);
    return r;
}

static const wpd_dim *dim(const wpd_header *h, const char *name)
{
    int k = wpd_schema_find(&h->schema, name);
    return k >= 0 ? &h->schema.dims[k] : NULL;
}

TEST(las_extra_bytes_described)
{
    wpd_reader *r = open_data("las/pdal_extrabytes.las", failures_);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->las.extra_bytes == 27 && h->schema.record_size == 61);
    const wpd_dim *c2 = dim(h, "Colors[2]"), *f1 = dim(h, "Flags[1]");
    const wpd_dim *in = dim(h, "Intensity"), *t = dim(h, "Time");
    CHECK(c2 && c2->type == WPD_U16 && c2->offset == 38);
    CHECK(f1 && f1->type == WPD_I8 && f1->offset == 48);  /* after 7 undocumented bytes */
    CHECK(in && in->type == WPD_U32 && in->offset == 49);
    CHECK(t && t->type == WPD_U64 && t->offset == 53);
    CHECK(dim(h, "intensity") && dim(h, "gps_time") && dim(h, "red"));
    wpd_reader_close(r);

    /* Scaled descriptors, names with spaces made usable. */
    r = open_data("las/laszip_5points_14.las", failures_);
    if (!r)
        return;
    h = wpd_reader_header(r);
    const wpd_dim *hag = dim(h, "height_above_ground");
    CHECK(hag && hag->type == WPD_I16 && hag->offset == 30 && hag->scaled &&
          hag->scale == 0.05);
    CHECK(dim(h, "coverage_count") && dim(h, "overlap") && dim(h, "scanner_channel"));
    wpd_reader_close(r);
}

TEST(las_extra_bytes_undescribed)
{
    wpd_reader *r = open_data("las/laspy_unregistered_extra_bytes.las", failures_);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->las.extra_bytes == 4 && h->las.point_count == 4);
    for (int i = 0; i < 4; i++) {
        char name[32];
        snprintf(name, sizeof name, "extra_byte_%d", i);
        const wpd_dim *d = dim(h, name);
        CHECK_MSG(d && d->type == WPD_U8 && d->offset == 30u + (unsigned)i, "%s", name);
    }
    CHECK(h->schema.ndims == 3 + 15 + 4);
    wpd_reader_close(r);
}

TEST(las_64bit_counts_and_bit_fields)
{
    wpd_reader *r = open_data("las/pdal_autzen-bmx-2010.las", failures_);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->point_count == 829 && h->las.point_count == 829);
    uint64_t sum = 0;
    for (int i = 0; i < 15; i++)
        sum += h->las.points_by_return[i];
    CHECK_MSG(sum == 829, "by return sum %llu", (unsigned long long)sum);
    const wpd_dim *rn = dim(h, "return_number"), *cls = dim(h, "classification");
    CHECK(rn && rn->bit_count == 4 && rn->offset == 14 && cls && cls->offset == 16);
    CHECK(dim(h, "scan_angle") && !dim(h, "scan_angle_rank"));
    wpd_reader_close(r);

    /* Classification flag bits of PDRF 3. */
    r = open_data("las/pdal_synthetic_test.las", failures_);
    if (!r)
        return;
    h = wpd_reader_header(r);
    wpd_batch b;
    wpd_error err;
    if (wpd_batch_init(&b, 4, h->schema.record_size) == 0) {
        CHECK(wpd_reader_read(r, &b, &err) == 1);
        CHECK(wpd_dim_get(dim(h, "x"), b.records) == 1.0 && b.xyz[1] == 2.0 && b.xyz[2] == 3.0);
        double s = wpd_dim_get(dim(h, "synthetic"), b.records);
        double k = wpd_dim_get(dim(h, "key_point"), b.records);
        double w = wpd_dim_get(dim(h, "withheld"), b.records);
        CHECK_MSG(s + k + w >= 1, "flags %g %g %g", s, k, w);
        CHECK(dim(h, "classification")->bit_count == 5);
        wpd_batch_free(&b);
    }
    wpd_reader_close(r);
}

TEST(las_seek)
{
    wpd_reader *r = open_data("las/pdal_simple.las", failures_);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    cf_cloud p;
    wpd_error err;
    CHECK(wpd_reader_can_seek(r));
    CHECK(cf_read_all(r, &p, 100, &err) == 0 && p.n == 1065);
    wpd_batch b;
    if (wpd_batch_init(&b, 10, h->schema.record_size) == 0) {
        CHECK(wpd_reader_seek(r, 500, &err) == 0);
        CHECK(wpd_reader_read(r, &b, &err) == 10);
        CHECK(!memcmp(b.records, p.records + 500 * 34, 10 * 34));
        CHECK(b.xyz[0] == p.xyz[1500] && b.xyz[29] == p.xyz[3 * 509 + 2]);
        CHECK(wpd_reader_seek(r, 1060, &err) == 0);
        CHECK(wpd_reader_read(r, &b, &err) == 5);
        CHECK(wpd_reader_read(r, &b, &err) == 0);
        CHECK(wpd_reader_seek(r, 1065, &err) == 0 && wpd_reader_read(r, &b, &err) == 0);
        CHECK(wpd_reader_seek(r, 1066, &err) == -1);
        CHECK(wpd_reader_seek(r, 0, &err) == 0 && wpd_reader_read(r, &b, &err) == 10);
        CHECK(!memcmp(b.records, p.records, 10 * 34));
        wpd_batch_free(&b);
    }
    cf_cloud_free(&p);
    wpd_reader_close(r);
}

/* ------------------------------------------------------------ synthetic files */

TEST(las_synthetic_valid_file)
{
    static uint8_t buf[8192];
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 3, 34, 10, 1};
    size_t len = lt_build_las(buf, &s);
    char path[1024];
    cf_tmp_path(path, sizeof path, "valid.las");
    CHECK(cf_write_file(path, buf, len) == 0);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r, "%s", err.msg);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->point_count == 10 && h->las.nvlr == 1 && h->las.vlrs[0].length == 10 &&
          !strcmp(h->las.vlrs[0].user_id, "test") && !memcmp(h->las.vlrs[0].data, "0123", 4));
    cf_cloud p;
    CHECK(cf_read_all(r, &p, 3, &err) == 0 && p.n == 10);
    CHECK(p.xyz[27] == 1009.0 && p.xyz[28] == 1995.5 && p.xyz[29] == 0.07);
    cf_cloud_free(&p);
    wpd_reader_close(r);
}

TEST(las_synthetic_malformed_files)
{
    static uint8_t buf[8192], mod[8192];
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 3, 34, 10, 1};
    size_t len = lt_build_las(buf, &s);

    lt_expect_failure(failures_, "trunc_header.las", buf, 100, "truncated header");
    lt_expect_failure(failures_, "trunc_points.las", buf, len - 1, "needs 340 bytes");

    memcpy(mod, buf, len);
    mod[104] |= 0x80;
    lt_expect_failure(failures_, "laz_bit.las", mod, len, "(LAZ) but there is no LASzip VLR");
    memcpy(mod, buf, len);
    mod[104] |= 0x40;
    lt_expect_failure(failures_, "laz_bit6.las", mod, len, "LAZ");

    memcpy(mod, buf, len);
    mod[227 + 20] = 200; /* VLR payload length beyond the point data */
    lt_expect_failure(failures_, "vlr_len.las", mod, len, "VLR 1 of 1");
    memcpy(mod, buf, len);
    mod[100] = 2; /* a second VLR that does not exist */
    lt_expect_failure(failures_, "vlr_count.las", mod, len, "VLR 2 of 2");
    memcpy(mod, buf, len);
    memcpy(mod + 100, (uint32_t[]){0xFFFFFFFFu}, 4);
    lt_expect_failure(failures_, "vlr_garbage.las", mod, len, "VLR 2 of 4294967295");

    memcpy(mod, buf, len);
    memcpy(mod + 227 + 2, "laszip encoded\0\0", 16);
    mod[227 + 18] = 0xBC, mod[227 + 19] = 0x56; /* 22204 */
    lt_expect_failure(failures_, "laz_vlr.las", mod, len, "LAZ");

    memcpy(mod, buf, len);
    mod[104] = 11;
    lt_expect_failure(failures_, "pdrf11.las", mod, len, "point data record format 11");
    memcpy(mod, buf, len);
    mod[105] = 30; /* record_length < 34 */
    lt_expect_failure(failures_, "reclen.las", mod, len, "record_length 30");
    memcpy(mod, buf, len);
    mod[94] = 200; /* header_size < 227 */
    lt_expect_failure(failures_, "hsize.las", mod, len, "header_size 200");
    memcpy(mod, buf, len);
    mod[25] = 5;
    lt_expect_failure(failures_, "version.las", mod, len, "LAS version 1.5");
    memcpy(mod, buf, len);
    memcpy(mod + 96, (uint32_t[]){100}, 4);
    lt_expect_failure(failures_, "ptoff.las", mod, len, "offset_to_point_data 100");
    memcpy(mod, buf, len);
    memcpy(mod + 131, (double[]){0.0}, 8);
    lt_expect_failure(failures_, "scale0.las", mod, len, "x scale");
    memcpy(mod, buf, len);
    memcpy(mod + 107, (uint32_t[]){0xFFFFFFFFu}, 4);
    lt_expect_failure(failures_, "count.las", mod, len, "point count 4294967295");

    /* 1.4: an EVLR start inside the points (an EVLR past the end of the
     * file is only a warning: test_las_lenient.c). */
    memset(buf, 0, sizeof buf);
    s = (lt_synth){4, 6, 30, 4, 0};
    len = lt_build_las(buf, &s);
    memcpy(mod, buf, len);
    mod[243] = 1;
    memcpy(mod + 235, (uint64_t[]){len - 30}, 8);
    lt_expect_failure(failures_, "evlr_inside.las", mod, len,
                      "start_of_first_evlr 465 lies inside the point data");
}

TEST(las_synthetic_counts_14)
{
    static uint8_t buf[8192];
    memset(buf, 0, sizeof buf);
    lt_synth s = {4, 1, 28, 6, 0};
    size_t len = lt_build_las(buf, &s);
    memcpy(buf + 107, (uint32_t[]){5}, 4); /* legacy disagrees: 64-bit wins */
    char path[1024];
    cf_tmp_path(path, sizeof path, "counts14.las");
    CHECK(cf_write_file(path, buf, len) == 0);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r, "%s", err.msg);
    if (r) {
        CHECK(wpd_reader_header(r)->point_count == 6);
        wpd_reader_close(r);
    }
    /* 64-bit count 0 next to a legacy count: the legacy one is used. */
    memcpy(buf + 247, (uint64_t[]){0}, 8);
    CHECK(cf_write_file(path, buf, len) == 0);
    r = wpd_reader_open(path, &err);
    CHECK_MSG(r, "%s", err.msg);
    if (r) {
        CHECK(wpd_reader_header(r)->point_count == 5);
        wpd_reader_close(r);
    }
}

/* ------------------------------------------------------------ writer */

static void read_bytes(const char *path, uint8_t *buf, size_t cap, size_t *len)
{
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (f) {
        *len = fread(buf, 1, cap, f);
        fclose(f);
    }
}

TEST(las_writer_header_fields)
{
    static uint8_t buf[8192], out[8192];
    memset(buf, 0, sizeof buf);
    lt_synth s = {4, 6, 30, 9, 1};
    size_t len = lt_build_las(buf, &s);
    char in_path[1024], out_path[1024];
    cf_tmp_path(in_path, sizeof in_path, "w_in.las");
    cf_tmp_path(out_path, sizeof out_path, "w_out.las");
    CHECK(cf_write_file(in_path, buf, len) == 0);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(in_path, &err);
    CHECK_MSG(r, "%s", err.msg);
    if (!r)
        return;
    cf_cloud p;
    CHECK(cf_read_all(r, &p, 64, &err) == 0);
    /* Shift the points: bounds and returns come from what is written. */
    p.xyz[0] = 990.0;
    uint8_t before[9 * 30];
    memcpy(before, p.records, sizeof before);
    CHECK(lt_write_points(out_path, wpd_reader_header(r), &p, 4, &err) == 0);
    CHECK_MSG(!memcmp(before, p.records, sizeof before), "caller's records modified");
    size_t n;
    read_bytes(out_path, out, sizeof out, &n);
    CHECK(n == len);
    uint32_t legacy;
    uint64_t count, by_return[3];
    double minx;
    memcpy(&legacy, out + 107, 4);
    memcpy(&count, out + 247, 8);
    memcpy(by_return, out + 255, 24);
    memcpy(&minx, out + 187, 8);
    CHECK(legacy == 0 && count == 9); /* PDRF 6: legacy count 0 */
    CHECK(by_return[0] == 3 && by_return[1] == 3 && by_return[2] == 3);
    CHECK(minx == 990.0);
    CHECK(!memcmp(out + 58, WPD_SOFTWARE, sizeof WPD_SOFTWARE)); /* with its NUL */
    CHECK(!memcmp(out + 26, "synthetic", 9));
    cf_cloud_free(&p);
    wpd_reader_close(r);
}

TEST(las_writer_rejects_unrepresentable_coordinates)
{
    static uint8_t buf[8192];
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 0, 20, 3, 0};
    size_t len = lt_build_las(buf, &s);
    char in_path[1024], out_path[1024];
    cf_tmp_path(in_path, sizeof in_path, "q_in.las");
    cf_tmp_path(out_path, sizeof out_path, "q_out.las");
    CHECK(cf_write_file(in_path, buf, len) == 0);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(in_path, &err);
    if (!r) {
        CHECK_MSG(0, "%s", err.msg);
        return;
    }
    cf_cloud p;
    CHECK(cf_read_all(r, &p, 64, &err) == 0);
    p.xyz[7] = 1e12; /* y of point 2 with scale 0.01 */
    CHECK(lt_write_points(out_path, wpd_reader_header(r), &p, 64, &err) == -1);
    CHECK_MSG(lt_starts_with(err.msg, out_path) && strstr(err.msg, "point 2: y"), "%s", err.msg);
    struct stat st;
    CHECK(stat(out_path, &st) != 0); /* no partial output */
    p.xyz[7] = NAN;
    CHECK(lt_write_points(out_path, wpd_reader_header(r), &p, 64, &err) == -1);
    cf_cloud_free(&p);
    wpd_reader_close(r);
}

/* A header may declare records of up to 64 KB: a batch of 65536 of them
 * must not ask for 4 GB. */
TEST(batch_of_huge_records_stays_small)
{
    wpd_batch b;
    CHECK(wpd_batch_init(&b, 65536, 65535) == 0);
    CHECK_MSG(b.cap >= 1 && b.cap * 65535 <= WPD_BATCH_MAX_BYTES, "cap %zu", b.cap);
    wpd_batch_free(&b);
    CHECK(wpd_batch_init(&b, 65536, 34) == 0);
    CHECK(b.cap == 65536);
    wpd_batch_free(&b);
}
