/* laz_write.c - the LAZ point-wise chunked compressor (point formats 0-3)
 * and the layered chunked compressor (6-8) under the LAS writer
 * (contracts in laz.h).
 *
 * Layout written (LAZ specification 1.4), from the LAS header's offset to
 * the point data: an i64, the file offset of the chunk table (patched at
 * the end); the chunks, each of wpd_laz_chunk_points() points (the last
 * one fewer): the first record raw, the others arithmetic-coded item by item
 * (laz_items_enc.c), or, layered, each attribute group in its own stream
 * with the byte counts before them (laz_layered.c); then the chunk table:
 * u32 version 0, u32 chunk count,
 * and an arithmetic stream of each chunk's byte size coded against the
 * previous one (integer compressor of 32 bits, context 1; fixed chunks
 * need no point counts). A chunk is encoded in memory and written whole,
 * so its size is known when the next one starts.
 */
#include "io/laz/laz.h"
#include "common/testhook.h"
#include "io/las/las_internal.h"
#include "io/laz/laz_items.h"
#include "io/laz/laz_layered.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { LAZ_VLR_FIXED = 34, LAZ_VLR_ITEM = 6 };

struct wpd_laz_writer {
    const char *path;             /* for messages (the writer's final path) */
    laz_items *items;             /* point-wise, or */
    laz_layered *layered;         /* layered (point formats 6-8) */
    uint8_t *first;               /* layered: the open chunk's first record */
    laz_out out;                  /* the open chunk */
    laz_enc enc;
    uint32_t record_length;
    uint32_t in_chunk;            /* points in the open chunk */
    uint32_t *sizes;              /* byte size of each closed chunk */
    size_t nchunks, cap;
    uint64_t chunk_bytes;         /* bytes of the closed chunks */
    wpd_laz_info info;
    uint8_t vlr[LAZ_VLR_FIXED + LAZ_VLR_ITEM * WPD_LAZ_MAX_ITEMS];
};

/* ---- the LASzip VLR ---- */

/* The items of point format pdrf with extra extra bytes, in record order:
 * version 2 items of the point-wise compressor (formats 0-3), version 3
 * of the layered one (6-8). */
static void choose_items(wpd_laz_info *z, uint8_t pdrf, uint16_t extra)
{
    int n = 0;
    if (pdrf >= 6) {
        z->items[n++] = (wpd_laz_item){LAZ_ITEM_POINT14, 30, 3};
        if (pdrf == 7)
            z->items[n++] = (wpd_laz_item){LAZ_ITEM_RGB14, 6, 3};
        if (pdrf == 8)
            z->items[n++] = (wpd_laz_item){LAZ_ITEM_RGBNIR14, 8, 3};
        if (extra)
            z->items[n++] = (wpd_laz_item){LAZ_ITEM_BYTE14, extra, 3};
        z->nitems = (uint16_t)n;
        return;
    }
    z->items[n++] = (wpd_laz_item){LAZ_ITEM_POINT10, 20, 2};
    if (pdrf == 1 || pdrf == 3)
        z->items[n++] = (wpd_laz_item){LAZ_ITEM_GPSTIME11, 8, 2};
    if (pdrf == 2 || pdrf == 3)
        z->items[n++] = (wpd_laz_item){LAZ_ITEM_RGB12, 6, 2};
    if (extra)
        z->items[n++] = (wpd_laz_item){LAZ_ITEM_BYTE, extra, 2};
    z->nitems = (uint16_t)n;
}

/* The payload of the LASzip VLR (layout in laz_vlr.c): the compressor,
 * arithmetic coder, the LASzip version whose items these are (2.2; 3.4 for
 * layered), fixed chunks, no special EVLRs (-1, -1). */
static void encode_vlr(const wpd_laz_info *z, uint8_t *p)
{
    memset(p, 0, LAZ_VLR_FIXED);
    las_put_u16(p, z->compressor);
    las_put_u16(p + 2, z->coder);
    p[4] = z->version_major;
    p[5] = z->version_minor;
    las_put_u16(p + 6, z->version_revision);
    las_put_u32(p + 8, z->options);
    las_put_u32(p + 12, z->chunk_size);
    las_put_u64(p + 16, UINT64_MAX);
    las_put_u64(p + 24, UINT64_MAX);
    las_put_u16(p + 32, z->nitems);
    for (uint16_t i = 0; i < z->nitems; i++) {
        uint8_t *q = p + LAZ_VLR_FIXED + LAZ_VLR_ITEM * i;
        las_put_u16(q, z->items[i].type);
        las_put_u16(q + 2, z->items[i].size);
        las_put_u16(q + 4, z->items[i].version);
    }
}

void wpd_laz_writer_vlr(const wpd_laz_writer *z, wpd_vlr *v)
{
    memset(v, 0, sizeof *v);
    snprintf(v->user_id, sizeof v->user_id, "%s", WPD_LAZ_VLR_USER);
    snprintf(v->description, sizeof v->description, WPD_LAZ_VLR_DESCRIPTION " (%s)",
             wpd_laz_compressor_name(z->info.compressor));
    v->record_id = WPD_LAZ_VLR_RECORD;
    v->length = LAZ_VLR_FIXED + LAZ_VLR_ITEM * (uint64_t)z->info.nitems;
    v->data = (uint8_t *)z->vlr;
}

/* ---- create ---- */

uint32_t wpd_laz_chunk_points(void)
{
    /* LASzip's largest fixed chunk is UINT32_MAX - 1 (the maximum means
     * variable chunks there). */
    return (uint32_t)wpd_test_number("WPD_TEST_LAZ_CHUNK", WPD_LAZ_CHUNK_POINTS, UINT32_MAX - 1);
}

wpd_laz_writer *wpd_laz_writer_create(const char *path, uint8_t pdrf, uint16_t record_length,
                                      wpd_error *err)
{
    if ((pdrf > 3 && pdrf < 6) || pdrf > 8) {
        wpd_fail(err, WPD_E_USAGE,
                 "%s: cannot write LAZ point format %u (waveform packets are not compressed; "
                 "formats 0-3 and 6-8 are; write .las instead)",
                 path, pdrf);
        return NULL;
    }
    wpd_laz_writer *z = calloc(1, sizeof *z);
    if (!z) {
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
        return NULL;
    }
    z->path = path;
    z->record_length = record_length;
    int layered = pdrf >= 6;
    z->info = (wpd_laz_info){.compressed = 1, .compressor = layered ? 3 : 2, .coder = 0,
                             .version_major = layered ? 3 : 2, .version_minor = layered ? 4 : 2,
                             .version_revision = layered ? 3 : 0,
                             .chunk_size = wpd_laz_chunk_points()};
    choose_items(&z->info, pdrf, (uint16_t)(record_length - las_pdrf_size[pdrf]));
    encode_vlr(&z->info, z->vlr);
    if (layered ? !(z->layered = laz_layered_create(z->info.items, z->info.nitems)) ||
                      !(z->first = malloc(record_length))
                : !(z->items = laz_items_create(z->info.items, z->info.nitems))) {
        wpd_laz_writer_free(z);
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
        return NULL;
    }
    return z;
}

void wpd_laz_writer_free(wpd_laz_writer *z)
{
    if (!z)
        return;
    laz_items_free(z->items);
    laz_layered_free(z->layered);
    free(z->first);
    laz_out_free(&z->out);
    free(z->sizes);
    free(z);
}

/* ---- chunks ---- */

static int fail_memory(const wpd_laz_writer *z, wpd_error *err)
{
    return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a LAZ chunk", z->path);
}

/* Room for the sizes of n more chunks. */
static int room_for_chunks(wpd_laz_writer *z, size_t n)
{
    if (z->nchunks + n <= z->cap)
        return 0;
    size_t cap = z->cap ? 2 * z->cap : 64;
    while (cap < z->nchunks + n)
        cap *= 2;
    uint32_t *s = realloc(z->sizes, cap * sizeof *s);
    if (!s)
        return -1;
    z->sizes = s, z->cap = cap;
    return 0;
}

/* Ends the open chunk and writes it out. */
static int close_chunk(wpd_laz_writer *z, wpd_outfile *f, wpd_error *err)
{
    if (z->layered) {
        laz_out_clear(&z->out);
        if (laz_layered_finish(z->layered, &z->out, z->first, z->record_length, z->in_chunk))
            return fail_memory(z, err);
    } else {
        laz_enc_done(&z->enc);
    }
    if (z->out.oom)
        return fail_memory(z, err);
    if (room_for_chunks(z, 1))
        return fail_memory(z, err);
    z->sizes[z->nchunks++] = (uint32_t)z->out.len;
    z->chunk_bytes += z->out.len;
    z->in_chunk = 0;
    return wpd_outfile_write(f, z->out.buf, z->out.len, err);
}

int wpd_laz_writer_begin(wpd_laz_writer *z, wpd_outfile *f, wpd_error *err)
{
    (void)z;
    static const uint8_t placeholder[8] = {0}; /* the table offset, patched at the end */
    return wpd_outfile_write(f, placeholder, sizeof placeholder, err);
}

/* One record into the open layered chunk (its first: kept raw). */
static int put_layered(wpd_laz_writer *z, const uint8_t *rec)
{
    if (z->in_chunk)
        return laz_layered_encode(z->layered, rec);
    memcpy(z->first, rec, z->record_length);
    return laz_layered_start_encode(z->layered, rec);
}

int wpd_laz_writer_put(wpd_laz_writer *z, wpd_outfile *f, const uint8_t *rec, size_t n,
                       wpd_error *err)
{
    const uint32_t len = z->record_length;
    for (size_t i = 0; i < n; i++, rec += len) {
        if (z->layered) {
            if (put_layered(z, rec))
                return fail_memory(z, err);
        } else if (z->in_chunk == 0) { /* a chunk opens with its record raw */
            laz_out_clear(&z->out);
            laz_out_bytes(&z->out, rec, len);
            laz_items_start(z->items, rec);
            laz_enc_init(&z->enc, &z->out);
        } else if (laz_items_encode(z->items, &z->enc, rec)) {
            return fail_memory(z, err);
        }
        if (++z->in_chunk == z->info.chunk_size && close_chunk(z, f, err))
            return -1;
    }
    return 0;
}

/* ---- chunk table ---- */

/* The table's bytes into z->out. */
static int encode_table(wpd_laz_writer *z)
{
    uint8_t head[8];
    las_put_u32(head, 0);
    las_put_u32(head + 4, (uint32_t)z->nchunks);
    laz_out_clear(&z->out);
    laz_out_bytes(&z->out, head, sizeof head);
    if (!z->nchunks)
        return z->out.oom ? -1 : 0;
    laz_ic ic;
    if (laz_ic_create(&ic, 32, 2)) {
        laz_ic_free(&ic);
        return -1;
    }
    laz_enc_init(&z->enc, &z->out);
    uint32_t prev = 0;
    for (size_t i = 0; i < z->nchunks; i++) {
        laz_ic_encode(&ic, &z->enc, (int32_t)prev, (int32_t)z->sizes[i], 1);
        prev = z->sizes[i];
    }
    laz_enc_done(&z->enc);
    laz_ic_free(&ic);
    return z->out.oom ? -1 : 0;
}

int wpd_laz_writer_finish(wpd_laz_writer *z, wpd_outfile *f, uint64_t points_start,
                          uint64_t *end, wpd_error *err)
{
    if (z->in_chunk && close_chunk(z, f, err))
        return -1;
    if (z->nchunks > UINT32_MAX)
        return wpd_fail(err, WPD_E_INPUT, "%s: too many LAZ chunks", z->path);
    uint64_t table = points_start + 8 + z->chunk_bytes;
    if (encode_table(z))
        return fail_memory(z, err);
    uint8_t at[8];
    las_put_u64(at, table);
    if (wpd_outfile_write(f, z->out.buf, z->out.len, err) ||
        wpd_outfile_pwrite(f, at, sizeof at, (long long)points_start, err))
        return -1;
    *end = table + z->out.len;
    return 0;
}

int wpd_laz_writer_end_part(wpd_laz_writer *z, wpd_outfile *f, uint64_t *nchunks,
                            const uint32_t **sizes, wpd_error *err)
{
    if (z->in_chunk && close_chunk(z, f, err))
        return -1;
    *nchunks = z->nchunks;
    *sizes = z->sizes;
    return 0;
}

int wpd_laz_writer_add_chunks(wpd_laz_writer *z, const uint32_t *sizes, uint64_t n,
                              uint64_t bytes, wpd_error *err)
{
    if (z->in_chunk) /* a part after a chunk cut short: the table would lie */
        return wpd_fail(err, WPD_E_USAGE, "internal error: %s: a part after %u points of a "
                        "chunk", z->path, z->in_chunk);
    if (n > SIZE_MAX / sizeof *sizes || room_for_chunks(z, (size_t)n))
        return fail_memory(z, err);
    if (n) /* an empty part has no table: memcpy's source must not be NULL */
        memcpy(z->sizes + z->nchunks, sizes, (size_t)n * sizeof *sizes);
    z->nchunks += (size_t)n;
    z->chunk_bytes += bytes;
    return 0;
}
