/* test_las_extra.c - appending a described field to the records of a LAS
 * header (io/las_extra.c): after undescribed extra bytes, after described
 * ones, and in place of an Extra Bytes VLR the reader ignores. */
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "io/las/las.h"

/* A LAS 1.2 header of point format 0 with `extra` extra bytes and, when
 * ndesc > 0, an Extra Bytes VLR of those descriptors (copied). */
static void make_header(wpd_header *h, int extra, const uint8_t *desc, int ndesc)
{
    memset(h, 0, sizeof *h);
    h->format = WPD_FMT_LAS;
    strcpy(h->path, "test.las");
    h->las.version_major = 1, h->las.version_minor = 2, h->las.pdrf = 0;
    h->las.record_length = (uint16_t)(20 + extra);
    h->las.extra_bytes = (uint16_t)extra;
    for (int k = 0; k < 3; k++)
        h->las.scale[k] = 0.01;
    if (ndesc) {
        h->las.vlrs = calloc(1, sizeof *h->las.vlrs);
        strcpy(h->las.vlrs[0].user_id, "LASF_Spec");
        h->las.vlrs[0].record_id = 4;
        h->las.vlrs[0].length = 192u * (unsigned)ndesc;
        h->las.vlrs[0].data = malloc(192u * (unsigned)ndesc);
        memcpy(h->las.vlrs[0].data, desc, 192u * (unsigned)ndesc);
        h->las.nvlr = 1;
    }
    wpd_error err;
    wpd_las_schema_from_info(h, &err);
}

/* data_type and options of descriptor i of the header's Extra Bytes VLR. */
static int dtype(const wpd_header *h, int i) { return h->las.vlrs[h->las.nvlr - 1].data[192 * i + 2]; }
static int option(const wpd_header *h, int i) { return h->las.vlrs[h->las.nvlr - 1].data[192 * i + 3]; }

TEST(las_append_extra_after_undescribed_and_described_bytes)
{
    wpd_header h;
    wpd_error err;
    /* Three undescribed extra bytes, no VLR. */
    make_header(&h, 3, NULL, 0);
    CHECK(wpd_las_append_extra(&h, "edge", WPD_U8, "sharp", &err) == 0);
    CHECK(h.las.record_length == 24 && h.las.extra_bytes == 4 && h.las.nvlr == 1);
    CHECK(h.las.vlrs[0].length == 2 * 192 && dtype(&h, 0) == 0 && option(&h, 0) == 3);
    CHECK(dtype(&h, 1) == 1 && !strcmp((const char *)h.las.vlrs[0].data + 192 + 4, "edge"));
    int d = wpd_schema_find(&h.schema, "edge");
    CHECK(d >= 0 && h.schema.dims[d].offset == 23 && h.schema.record_size == 24);
    wpd_header_free(&h);
    /* One described byte ("a"), two undescribed after it. */
    uint8_t desc[192];
    wpd_las_put_descriptor(desc, WPD_U8, "a", "");
    make_header(&h, 3, desc, 1);
    CHECK(wpd_las_append_extra(&h, "edge", WPD_U8, "sharp", &err) == 0);
    CHECK(h.las.vlrs[0].length == 3 * 192 && dtype(&h, 0) == 1 && dtype(&h, 1) == 0 &&
          option(&h, 1) == 2 && dtype(&h, 2) == 1);
    CHECK(h.schema.dims[wpd_schema_find(&h.schema, "a")].offset == 20);
    CHECK(h.schema.dims[wpd_schema_find(&h.schema, "edge")].offset == 23);
    wpd_header_free(&h);
    /* A VLR the reader ignores (unknown data type) is replaced. */
    desc[2] = 99;
    make_header(&h, 2, desc, 1);
    CHECK(wpd_las_append_extra(&h, "edge", WPD_U8, "sharp", &err) == 0);
    CHECK(h.las.nvlr == 1 && h.las.vlrs[0].length == 2 * 192 && dtype(&h, 0) == 0 &&
          option(&h, 0) == 2 && dtype(&h, 1) == 1);
    CHECK(h.schema.dims[wpd_schema_find(&h.schema, "edge")].offset == 22);
    wpd_header_free(&h);
    /* More undescribed bytes than one descriptor counts (255). */
    make_header(&h, 300, NULL, 0);
    CHECK(wpd_las_append_extra(&h, "edge", WPD_U8, "sharp", &err) == 0);
    CHECK(h.las.vlrs[0].length == 3 * 192 && option(&h, 0) == 255 && option(&h, 1) == 45);
    CHECK(h.schema.dims[wpd_schema_find(&h.schema, "edge")].offset == 320);
    wpd_header_free(&h);
}
