/* test_write_parts.c - one output written in parts (io/writer.h, what the
 * ranks of an MPI run do): the first writer writes its points into the
 * output, part writers theirs into part files, which are placed after it
 * at the prefix sum of the parts' bytes; the first writer adds the parts'
 * facts and closes. The file must be the bytes one writer writes, for LAS
 * (header counts, return histogram, bounds), LAZ of both compressors
 * (chunk table) and binary and ASCII PLY (vertex count, text of varying
 * length), with a part that holds no point. */
#include "harness.h"
#include "las_files.h"

#include "io/laz/laz.h"
#include "io/reader.h"
#include "io/writer.h"

#include <stdlib.h>
#include <string.h>

/* Points [lo, hi) of p through w. */
static int write_range(wpd_writer *w, const cf_cloud *p, size_t lo, size_t hi, wpd_error *err)
{
    wpd_batch b = {hi - lo, hi - lo, p->record_size, p->records + lo * p->record_size,
                   p->xyz + 3 * lo};
    return hi > lo ? wpd_writer_write(w, &b, err) : 0;
}

/* p written by one writer to name and in parts cut at cuts[0..ncuts-1]
 * to "parts-"name: 0 when the files are equal. */
static int parts_equal_one(int *failures_, const char *name, const wpd_header *h,
                           const cf_cloud *p, const size_t *cuts, int ncuts,
                           const wpd_write_options *opt)
{
    char one[1024], joined[1024], part_name[64], part_path[1024];
    char joined_name[80];
    snprintf(joined_name, sizeof joined_name, "parts-%s", name);
    cf_tmp_path(one, sizeof one, name);
    cf_tmp_path(joined, sizeof joined, joined_name);
    wpd_error err = {0};
    wpd_writer *w = wpd_writer_open(one, h, opt, &err);
    int rc = w && write_range(w, p, 0, p->n, &err) == 0 ? wpd_writer_close(w, &err) : -1;
    CHECK_MSG(rc == 0, "%s: %s", name, err.msg);
    /* The first writer, then the parts. */
    wpd_writer *first = wpd_writer_open(joined, h, opt, &err), *parts[4] = {0};
    wpd_write_part facts[4], mine;
    rc = first ? write_range(first, p, 0, cuts[0], &err) : -1;
    if (rc == 0)
        rc = wpd_writer_end_part(first, &mine, &err);
    uint64_t at = rc == 0 ? wpd_writer_records_end(first) : 0;
    for (int k = 0; rc == 0 && k < ncuts; k++) {
        size_t hi = k + 1 < ncuts ? cuts[k + 1] : p->n;
        snprintf(part_name, sizeof part_name, "part%d%s", k, strrchr(name, '.'));
        cf_tmp_path(part_path, sizeof part_path, part_name);
        rc = (parts[k] = wpd_writer_open_part(part_path, h, opt, &err)) &&
                     write_range(parts[k], p, cuts[k], hi, &err) == 0 &&
                     wpd_writer_end_part(parts[k], &facts[k], &err) == 0 &&
                     wpd_writer_place_part(parts[k], wpd_writer_temp_path(first), at, &err) == 0
                 ? 0 : -1;
        at += rc == 0 ? facts[k].bytes : 0;
        CHECK_MSG(rc || facts[k].count == hi - cuts[k], "%s: part %d holds %llu", name, k,
                  (unsigned long long)facts[k].count);
    }
    for (int k = 0; rc == 0 && k < ncuts; k++)
        rc = wpd_writer_add_part(first, &facts[k], &err);
    if (rc == 0)
        rc = wpd_writer_close(first, &err);
    else
        wpd_writer_abort(first);
    for (int k = 0; k < ncuts; k++)
        wpd_writer_abort(parts[k]);
    CHECK_MSG(rc == 0, "%s in parts: %s", name, err.msg);
    size_t la = 0, lb = 0;
    uint8_t *a = cf_read_file(one, &la), *b = cf_read_file(joined, &lb);
    int same = a && b && la == lb && !memcmp(a, b, la);
    CHECK_MSG(same, "%s: %zu bytes in parts, %zu from one writer", name, lb, la);
    free(a);
    free(b);
    return same ? 0 : -1;
}

/* A LAS cloud (lt_build_las) with coordinates that vary, read back. */
static int las_cloud(const char *name, uint8_t minor, uint8_t pdrf, uint16_t len, uint32_t n,
                     wpd_reader **r, cf_cloud *p)
{
    lt_synth s = {minor, pdrf, len, n, 1};
    uint8_t *buf = calloc(1, 4096 + (size_t)n * len);
    char path[1024];
    cf_tmp_path(path, sizeof path, name);
    int rc = buf && cf_write_file(path, buf, lt_build_las(buf, &s)) == 0 ? 0 : -1;
    free(buf);
    wpd_error err = {0};
    if (rc || !(*r = wpd_reader_open(path, &err)) || cf_read_all(*r, p, 65536, &err))
        return -1;
    for (size_t i = 0; i < p->n; i++) { /* a box and returns that differ by part */
        p->xyz[3 * i] += (double)(i % 977) * 0.37;
        p->xyz[3 * i + 1] -= (double)(i / 50000) * 11.0;
        p->records[i * p->record_size + 14] = (uint8_t)(pdrf >= 6 ? (i % 5 + 1) | 0x50
                                                                  : (i % 4 + 1) | 0x20);
    }
    return 0;
}

TEST(writer_parts_give_one_writers_las_and_laz)
{
    static const struct {
        uint8_t minor, pdrf;
        uint16_t len;
    } fmt[] = {{2, 3, 34}, {4, 7, 36 + 3}, {2, 1, 28}};
    const uint32_t chunk = WPD_LAZ_CHUNK_POINTS, n = 3 * chunk + 4321;
    /* Whole chunks but the last part; one part empty. */
    const size_t cuts[] = {chunk, 2 * chunk, 2 * chunk};
    for (size_t f = 0; f < sizeof fmt / sizeof *fmt; f++) {
        wpd_reader *r = NULL;
        cf_cloud p = {0};
        char base[64], las[64], laz[64];
        snprintf(base, sizeof base, "src%zu.las", f);
        CHECK(las_cloud(base, fmt[f].minor, fmt[f].pdrf, fmt[f].len, f == 2 ? 777 : n, &r,
                        &p) == 0);
        if (!r)
            continue;
        size_t small[] = {0, 0, 777}; /* fewer points than a chunk: parts empty */
        snprintf(las, sizeof las, "p%zu.las", f);
        snprintf(laz, sizeof laz, "p%zu.laz", f);
        parts_equal_one(failures_, las, wpd_reader_header(r), &p, f == 2 ? small : cuts, 3,
                        NULL);
        parts_equal_one(failures_, laz, wpd_reader_header(r), &p, f == 2 ? small : cuts, 3,
                        NULL);
        cf_cloud_free(&p);
        wpd_reader_close(r);
    }
}

TEST(writer_parts_give_one_writers_ply)
{
    enum { N = 5000 };
    char path[1024];
    cf_tmp_path(path, sizeof path, "src.ply");
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 5000\n"
                       "property double x\nproperty double y\nproperty double z\n"
                       "property uchar c\nend_header\n";
    size_t hl = strlen(head), rs = 25;
    uint8_t *buf = malloc(hl + N * rs);
    CHECK(buf != NULL);
    if (!buf)
        return;
    memcpy(buf, head, hl);
    for (int i = 0; i < N; i++) {
        double v[3] = {i * 0.125, (i % 97) * 1.0e-3 - 4, i % 7 ? 1.0 / (i + 1) : 1e6 * i};
        memcpy(buf + hl + i * rs, v, 24);
        buf[hl + i * rs + 24] = (uint8_t)(i * 13);
    }
    CHECK(cf_write_file(path, buf, hl + N * rs) == 0);
    free(buf);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    cf_cloud p = {0};
    CHECK_MSG(r && cf_read_all(r, &p, 1024, &err) == 0, "%s", err.msg);
    if (!r)
        return;
    const size_t cuts[] = {1200, 1200, 4000}; /* any cut: no chunks */
    wpd_write_options binary = {0}, ascii = {.ply_ascii = 1};
    parts_equal_one(failures_, "out.ply", wpd_reader_header(r), &p, cuts, 3, &binary);
    parts_equal_one(failures_, "out_ascii.ply", wpd_reader_header(r), &p, cuts, 3, &ascii);
    cf_cloud_free(&p);
    wpd_reader_close(r);
}
