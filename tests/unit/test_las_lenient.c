/* test_las_lenient.c - how the LAS reader treats files that bend the
 * specification (docs/formats.md, "LAS: lenient and strict"): each lenient
 * case reads with one warning line naming the file and gives the points the
 * file holds; each strict case fails with one line naming the file and the
 * field. The files are hand-made in memory from lt_build_las. */
#include "harness.h"
#include "las_files.h"

#include "common/printable.h"
#include "common/warnings.h"
#include "io/las/las.h"
#include "io/reader.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ helpers */

/* Inserts a VLR (header fields as given, payload plen bytes) after the
 * header and the VLRs already there; moves the points and fixes the point
 * offset and VLR count. user and desc are copied whole (16 and 32 bytes).
 * Returns the new file length. */
static size_t insert_vlr(uint8_t *buf, size_t len, const uint8_t user[16], uint16_t record_id,
                         const uint8_t desc[32], const uint8_t *payload, uint16_t plen)
{
    uint32_t off, nvlr;
    memcpy(&off, buf + 96, 4);
    memcpy(&nvlr, buf + 100, 4);
    size_t size = 54u + plen;
    memmove(buf + off + size, buf + off, len - off);
    uint8_t *v = buf + off;
    memcpy(v, (uint16_t[]){0xAABB}, 2); /* reserved: LAS 1.0's value, carried over */
    memcpy(v + 2, user, 16);
    memcpy(v + 18, &record_id, 2);
    memcpy(v + 20, &plen, 2);
    memcpy(v + 22, desc, 32);
    memcpy(v + 54, payload, plen);
    off += (uint32_t)size;
    nvlr++;
    memcpy(buf + 96, &off, 4);
    memcpy(buf + 100, &nvlr, 4);
    return len + size;
}

/* Checks that h holds exactly `count` warnings, each one line starting with
 * h->path, and (count > 0) that one of them contains expect. */
static void check_warnings(int *failures_, const char *name, const wpd_header *h, uint32_t count,
                           const char *expect)
{
    const wpd_warnings *w = &h->warnings;
    CHECK_MSG(w->n == count, "%s: %u warnings, want %u (first: \"%s\")", name, w->n, count,
              w->n ? w->line[0] : "");
    int found = 0;
    for (uint32_t i = 0; i < w->n; i++) {
        CHECK_MSG(lt_starts_with(w->line[i], h->path) && !strchr(w->line[i], '\n'),
                  "%s: warning \"%s\"", name, w->line[i]);
        found |= expect && strstr(w->line[i], expect) != NULL;
    }
    CHECK_MSG(!count || found, "%s: no warning contains \"%s\" (first: \"%s\")", name, expect,
              w->n ? w->line[0] : "");
}

/* Checks that p holds the n points lt_build_las writes. */
static void check_points(int *failures_, const char *name, const cf_cloud *p, uint32_t n)
{
    CHECK_MSG(p->n == n, "%s: %llu points, want %u", name, (unsigned long long)p->n, n);
    for (uint32_t i = 0; i < n && i < p->n; i++) {
        const double *v = p->xyz + 3 * i;
        CHECK_MSG(fabs(v[0] - (1000 + i)) < 1e-9 && fabs(v[1] - (2000 - 0.5 * i)) < 1e-9 &&
                      fabs(v[2] - 0.07) < 1e-12,
                  "%s: point %u is (%g, %g, %g)", name, i, v[0], v[1], v[2]);
    }
}

/* Writes the file, opens it, checks its warnings (count, one containing
 * expect) and that its points are the n lt_build_las wrote. Returns the
 * open reader (the caller closes it), or NULL. */
static wpd_reader *read_lenient(int *failures_, const char *name, const uint8_t *bytes,
                                size_t len, uint32_t nwarnings, const char *expect, uint32_t n)
{
    char path[1024];
    cf_tmp_path(path, sizeof path, name);
    CHECK(cf_write_file(path, bytes, len) == 0);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r, "%s: refused: %s", name, err.msg);
    if (!r)
        return NULL;
    check_warnings(failures_, name, wpd_reader_header(r), nwarnings, expect);
    cf_cloud p;
    CHECK_MSG(cf_read_all(r, &p, 3, &err) == 0, "%s: %s", name, err.msg);
    check_points(failures_, name, &p, n);
    cf_cloud_free(&p);
    CHECK(wpd_reader_seek(r, 0, &err) == 0);
    return r;
}

/* read_lenient for a file nothing else is asked of. */
static void lenient(int *failures_, const char *name, const uint8_t *bytes, size_t len,
                    uint32_t nwarnings, const char *expect, uint32_t n)
{
    wpd_reader_close(read_lenient(failures_, name, bytes, len, nwarnings, expect, n));
}

static uint8_t buf[16384], mod[16384], out[16384];

/* Reads the temp file name and writes it to the temp file copy_name (LAS ->
 * LAS), then loads the copy into out. Returns its size, 0 if the copy
 * failed. */
static size_t copy_las(int *failures_, const char *name, const char *copy_name)
{
    char in[1024], copy[1024];
    cf_tmp_path(in, sizeof in, name);
    cf_tmp_path(copy, sizeof copy, copy_name);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(in, &err);
    cf_cloud p = {0};
    int ok = r && cf_read_all(r, &p, 64, &err) == 0 &&
             lt_write_points(copy, wpd_reader_header(r), &p, 7, &err) == 0;
    CHECK_MSG(ok, "%s -> %s: %s", name, copy_name, err.msg);
    cf_cloud_free(&p);
    wpd_reader_close(r);
    FILE *f = ok ? fopen(copy, "rb") : NULL;
    size_t n = f ? fread(out, 1, sizeof out, f) : 0;
    if (f)
        fclose(f);
    return n;
}

/* ------------------------------------------------------------ waveform and EVLR pointers */

/* The LAS 1.3 file: PDRF 4, the waveform data kept in another file
 * (global encoding bit 2), start_of_waveform_data_packet_record past the end. */
TEST(las_lenient_waveform_pointer_past_end_13)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {3, 4, 57, 5, 1};
    size_t len = lt_build_las(buf, &s);
    buf[6] = 4; /* waveform data packets external */
    memcpy(buf + 227, (uint64_t[]){len + 4096}, 8);
    wpd_reader *r = read_lenient(failures_, "wave_past.las", buf, len, 1,
                                 "start_of_waveform_data_packet_record 4680 is not in the file "
                                 "after the point data (bytes 584 to 584); the waveform data "
                                 "are ignored",
                                 5);
    if (r) {
        const wpd_header *h = wpd_reader_header(r);
        CHECK(h->las.nevlr == 0 && h->las.nvlr == 1 && h->point_count == 5);
        wpd_reader_close(r);
    }
    /* Pointing into the header, or at an EVLR that runs past the end. */
    memcpy(mod, buf, len);
    memcpy(mod + 227, (uint64_t[]){100}, 8);
    lenient(failures_, "wave_header.las", mod, len, 1, "record 100 is not in the file", 5);
    memcpy(mod + 227, (uint64_t[]){len}, 8);
    memset(mod + len, 0, 60);
    memcpy(mod + len + 20, (uint64_t[]){1000000}, 8);
    lenient(failures_, "wave_short.las", mod, len + 60, 1,
            "runs past the end of the file at byte 644; the waveform data are ignored", 5);
    /* A waveform record that is there is read and kept. */
    memcpy(mod + len + 20, (uint64_t[]){4}, 8);
    memcpy(mod + len + 2, "LASF_Spec", 9);
    memcpy(mod + len + 18, (uint16_t[]){65535}, 2);
    r = read_lenient(failures_, "wave_ok.las", mod, len + 64, 0, NULL, 5);
    if (r) {
        CHECK(wpd_reader_header(r)->las.nevlr == 1);
        wpd_reader_close(r);
    }
}

TEST(las_lenient_evlr_pointers_14)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {4, 6, 30, 4, 0};
    size_t len = lt_build_las(buf, &s);
    memcpy(mod, buf, len);
    mod[243] = 1;
    memcpy(mod + 235, (uint64_t[]){len}, 8); /* the EVLR would start at the end */
    lenient(failures_, "evlr_end.las", mod, len, 1, "EVLR 1 of 1", 4);
    memcpy(mod + 235, (uint64_t[]){0}, 8); /* PDAL before 2.1 */
    lenient(failures_, "evlr_zero.las", mod, len, 1,
            "start_of_first_evlr 0 is not in the file after the point data", 4);
    memcpy(mod + 235, (uint64_t[]){1u << 30}, 8);
    lenient(failures_, "evlr_past.las", mod, len, 1, "the EVLRs are ignored", 4);
    /* A 1.4 waveform pointer is only reported. */
    memcpy(mod, buf, len);
    memcpy(mod + 227, (uint64_t[]){len + 1}, 8);
    lenient(failures_, "wave14.las", mod, len, 1,
            "start_of_waveform_data_packet_record 496 is not in the file", 4);
    /* An EVLR count of 0 makes the start irrelevant (PDAL writes the end of
     * the file there). */
    memcpy(mod, buf, len);
    memcpy(mod + 235, (uint64_t[]){len + 99}, 8);
    lenient(failures_, "evlr_none.las", mod, len, 0, NULL, 4);
}

/* ------------------------------------------------------------ counts, bytes */

TEST(las_lenient_point_counts_14)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {4, 1, 28, 6, 0};
    size_t len = lt_build_las(buf, &s);
    memcpy(mod, buf, len);
    memcpy(mod + 107, (uint32_t[]){5}, 4);
    lenient(failures_, "count_differ.las", mod, len, 1,
            "legacy_number_of_point_records 5 disagrees with number_of_point_records 6; the "
            "64-bit count is used",
            6);
    /* 64-bit count 0 next to a legacy one: the legacy one (here 5 of the 6
     * records, so one record's bytes are left over). */
    memcpy(mod + 247, (uint64_t[]){0}, 8);
    lenient(failures_, "count_zero64.las", mod, len, 2, "the legacy count is used", 5);
    /* Legacy 0 next to the 64-bit count is what LAS 1.4 allows. */
    memcpy(mod, buf, len);
    memcpy(mod + 107, (uint32_t[]){0}, 4);
    lenient(failures_, "count_legacy0.las", mod, len, 0, NULL, 6);
}

TEST(las_lenient_bytes_after_points)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 3, 34, 10, 1};
    size_t len = lt_build_las(buf, &s);
    memcpy(buf + len, "garbage", 7);
    lenient(failures_, "trailing.las", buf, len + 7, 1,
            "7 bytes after the 10 point records belong to no record; ignored", 10);
    /* A legacy count of 0 with records present: none is read as a point. */
    memcpy(buf + 107, (uint32_t[]){0}, 4);
    lenient(failures_, "count0.las", buf, len, 1, "340 bytes after the 0 point records", 0);
}

/* Bytes between the VLRs and the points (TerraScan, GeoCue): read without a
 * warning and written back. */
TEST(las_lenient_bytes_before_points_kept)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 3, 34, 10, 1};
    size_t len = lt_build_las(buf, &s);
    uint32_t off = 227 + 64;
    memmove(buf + off + 3, buf + off, len - off);
    memcpy(buf + off, "\x01\x02\x03", 3);
    memcpy(buf + 96, (uint32_t[]){off + 3}, 4);
    len += 3;
    wpd_reader *r = read_lenient(failures_, "gap.las", buf, len, 0, NULL, 10);
    if (!r)
        return;
    const wpd_las_info *las = &wpd_reader_header(r)->las;
    CHECK(las->vlr_tail_len == 3 && !memcmp(las->vlr_tail, "\x01\x02\x03", 3));
    wpd_reader_close(r);
    size_t n = copy_las(failures_, "gap.las", "gap_out.las");
    CHECK_MSG(n == len && !memcmp(out + 227, buf + 227, len - 227),
              "VLR, gap and points not carried over (%zu vs %zu bytes)", n, len);
}

/* A LAS 1.3 file whose header has the 227 bytes of 1.0-1.2. */
TEST(las_lenient_short_13_header)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 1, 28, 4, 1};
    size_t len = lt_build_las(buf, &s);
    buf[25] = 3;
    wpd_reader *r = read_lenient(failures_, "short13.las", buf, len, 1,
                                 "header_size 227 is smaller than the 235 bytes of a LAS 1.3 "
                                 "header",
                                 4);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->las.waveform_start == 0 && h->las.nevlr == 0 && h->las.nvlr == 1 &&
          !strcmp(h->las.vlrs[0].user_id, "test"));
    wpd_reader_close(r);
    /* Written back as a proper 1.3 file. */
    size_t n = copy_las(failures_, "short13.las", "short13_out.las");
    CHECK(n == len + 8 && out[25] == 3 && out[94] == 235);
    if (n)
        lenient(failures_, "short13_copy.las", out, n, 0, NULL, 4);
}

/* ------------------------------------------------------------ Extra Bytes VLR */

static size_t with_extra_bytes_vlr(uint8_t *file, uint8_t data_type, uint16_t length)
{
    memset(file, 0, sizeof buf);
    lt_synth s = {4, 0, 24, 3, 0}; /* 4 extra bytes per record */
    size_t len = lt_build_las(file, &s);
    uint8_t user[16] = "LASF_Spec", desc[32] = "Extra Bytes", payload[400] = {0};
    payload[2] = data_type;
    memcpy(payload + 4, "amplitude", 9);
    return insert_vlr(file, len, user, 4, desc, payload, length);
}

TEST(las_lenient_extra_bytes_vlr)
{
    size_t len = with_extra_bytes_vlr(buf, 9, 192); /* float: fits */
    wpd_reader *r = read_lenient(failures_, "eb_ok.las", buf, len, 0, NULL, 3);
    if (r) {
        const wpd_schema *sc = &wpd_reader_header(r)->schema;
        CHECK(wpd_schema_find(sc, "amplitude") >= 0 && wpd_schema_find(sc, "extra_byte_0") < 0);
        wpd_reader_close(r);
    }
    len = with_extra_bytes_vlr(buf, 10, 192); /* double: 8 bytes in a 4-byte room */
    r = read_lenient(failures_, "eb_long.las", buf, len, 1,
                     "runs past the 24-byte point record; the Extra Bytes VLR is ignored", 3);
    if (r) {
        const wpd_schema *sc = &wpd_reader_header(r)->schema;
        CHECK(wpd_schema_find(sc, "amplitude") < 0 && wpd_schema_find(sc, "extra_byte_3") >= 0);
        CHECK(sc->ndims == 3 + 12 + 4);
        wpd_reader_close(r);
    }
    len = with_extra_bytes_vlr(buf, 31, 192);
    lenient(failures_, "eb_type.las", buf, len, 1, "unknown data_type 31", 3);
    len = with_extra_bytes_vlr(buf, 9, 200);
    lenient(failures_, "eb_length.las", buf, len, 1,
            "Extra Bytes VLR length 200 is not a multiple of 192", 3);
}

/* ------------------------------------------------------------ VLR headers */

/* User id and description with bytes after the terminating NUL, in a VLR
 * and an EVLR: LAS -> LAS keeps all 16 + 32 bytes (and the reserved field)
 * of both; matching uses the text up to the NUL. */
TEST(las_vlr_and_evlr_headers_carried_byte_for_byte)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {4, 6, 30, 4, 0};
    size_t len = lt_build_las(buf, &s);
    const uint8_t user[16] = "vendor\0\x07\xff junk!", desc[32] = "histogram\0\x01\x02 left over";
    len = insert_vlr(buf, len, user, 42, desc, (const uint8_t *)"abc", 3);
    uint8_t *e = buf + len; /* the EVLR */
    memcpy(e, (uint16_t[]){7}, 2);
    memcpy(e + 2, "evlr\0\x1b[2J\0\0\0\0\0\0", 16);
    memcpy(e + 18, (uint16_t[]){9}, 2);
    memcpy(e + 20, (uint64_t[]){2}, 8);
    memcpy(e + 28, "wkt\0after the nul\x7f\x80\x90\0\0\0\0\0\0\0\0\0\0\0", 32);
    memcpy(e + 60, "xy", 2);
    memcpy(buf + 235, (uint64_t[]){len}, 8);
    buf[243] = 1;
    size_t total = len + 62;
    wpd_reader *r = read_lenient(failures_, "vlr_bytes.las", buf, total, 0, NULL, 4);
    if (!r)
        return;
    const wpd_las_info *las = &wpd_reader_header(r)->las;
    CHECK(las->nvlr == 1 && !strcmp(las->vlrs[0].user_id, "vendor") &&
          !strcmp(las->vlrs[0].description, "histogram") && las->vlrs[0].reserved == 0xAABB);
    CHECK(las->nevlr == 1 && !strcmp(las->evlrs[0].user_id, "evlr"));
    wpd_reader_close(r);
    size_t n = copy_las(failures_, "vlr_bytes.las", "vlr_bytes_out.las");
    CHECK(n == total);
    CHECK_MSG(!memcmp(out + 375, buf + 375, 54), "VLR header differs");
    CHECK_MSG(n == total && !memcmp(out + len, buf + len, 60), "EVLR header differs");
}

/* ------------------------------------------------------------ strict cases */

TEST(las_strict_cases_name_the_field)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {4, 6, 30, 4, 0};
    size_t len = lt_build_las(buf, &s);
    memcpy(mod, buf, len);
    memcpy(mod + 94, (uint16_t[]){235}, 2); /* 1.4 without its 64-bit counts */
    lt_expect_failure(failures_, "short14.las", mod, len, "header_size 235 is smaller");
    memcpy(mod, buf, len);
    memcpy(mod + 247, (uint64_t[]){5}, 8); /* one record more than the file holds */
    lt_expect_failure(failures_, "count64.las", mod, len, "header point count 5 needs 150");
    memset(buf, 0, sizeof buf);
    s = (lt_synth){3, 4, 57, 5, 0};
    len = lt_build_las(buf, &s);
    memcpy(mod, buf, len);
    memcpy(mod + 227, (uint64_t[]){300}, 8); /* inside the points */
    lt_expect_failure(failures_, "wave_inside.las", mod, len,
                      "start_of_waveform_data_packet_record 300 lies inside the point data");
    memcpy(mod, buf, len);
    memcpy(mod + 94, (uint16_t[]){226}, 2);
    lt_expect_failure(failures_, "short13_226.las", mod, len, "header_size 226");
}

/* ------------------------------------------------------------ wpd info's checks */

TEST(las_header_checked_against_points)
{
    memset(buf, 0, sizeof buf);
    lt_synth s = {2, 1, 28, 6, 0};
    size_t len = lt_build_las(buf, &s); /* no bounds, no return counts */
    wpd_reader *r = read_lenient(failures_, "audit.las", buf, len, 0, NULL, 6);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    cf_cloud p;
    wpd_error err;
    uint64_t by_return[16] = {0};
    wpd_bounds b;
    wpd_bounds_reset(&b);
    CHECK(cf_read_all(r, &p, 4, &err) == 0);
    wpd_las_tally_returns(h, p.records, p.n, by_return);
    wpd_bounds_add(&b, p.xyz, p.n);
    CHECK(by_return[1] == 2 && by_return[2] == 2 && by_return[3] == 2 && by_return[0] == 0);
    wpd_warnings w = {0};
    wpd_las_check_header_against_points(h, &b, by_return, &w);
    CHECK_MSG(w.n == 2 && strstr(w.line[0], "x header [0, 0] points [1000, 1005]") &&
                  strstr(w.line[1], "points by return (0 0 0) disagree with the points' "
                                    "return numbers (2 2 2)"),
              "%u: %s", w.n, w.line[0]);
    /* The same file with a true header: no warning (within a grid step). */
    wpd_header fixed = *h;
    const double lo[3] = {1000, 1997.5, 0.07}, hi[3] = {1005.004, 2000, 0.07};
    memcpy(fixed.las.min, lo, sizeof lo);
    memcpy(fixed.las.max, hi, sizeof hi);
    for (int i = 0; i < 3; i++)
        fixed.las.points_by_return[i] = 2;
    memset(&w, 0, sizeof w);
    wpd_las_check_header_against_points(&fixed, &b, by_return, &w);
    CHECK_MSG(w.n == 0, "%s", w.line[0]);
    cf_cloud_free(&p);
    wpd_reader_close(r);
}

/* ------------------------------------------------------------ text and warnings */

TEST(printable_escapes_what_a_terminal_would_act_on)
{
    char out[64];
    CHECK(!strcmp(wpd_printable(out, sizeof out, "a\x07\\b\x1b[2J\xff"),
                  "a\\x07\\\\b\\x1b[2J\\xff"));
    CHECK(!strcmp(wpd_printable(out, 6, "ab\x01"), "ab")); /* no half escape */
    CHECK(!strcmp(wpd_printable(out, 7, "ab\x01"), "ab\\x01"));
}

TEST(warnings_kept_and_counted_beyond_the_store)
{
    wpd_warnings w = {0};
    for (int i = 0; i < WPD_WARNINGS_MAX + 3; i++)
        wpd_warn(&w, "f.las: oddity %d\n%s", i, "second line");
    CHECK(w.n == WPD_WARNINGS_MAX && w.unstored == 3);
    CHECK(!strcmp(w.line[2], "f.las: oddity 2?second line"));
    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    if (!f)
        return;
    wpd_warnings_print(f, "info", &w);
    fclose(f);
    int lines = 0;
    for (const char *p = text; *p; p++)
        lines += *p == '\n';
    CHECK(lines == WPD_WARNINGS_MAX + 1);
    CHECK(lt_starts_with(text, "wpd info: warning: f.las: oddity 0?second line\n"));
    CHECK(strstr(text, "wpd info: warning: 3 more warnings about the same file not shown\n"));
    free(text);
}
