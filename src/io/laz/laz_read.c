/* laz_read.c - streaming reader of LAZ point data, point-wise compressor
 * (point formats 0-5), behind the reader interface (format.h).
 *
 * Layout (LAZ specification 1.4): the point data start with an i64, the
 * file offset of the chunk table (-1: it is in the file's last 8 bytes,
 * written so by encoders on non-seekable output). Chunks follow, each a
 * raw first record and then an arithmetic-coded stream of the rest. The
 * table (u32 version 0, u32 chunk count, then an arithmetic stream of each
 * chunk's point count - variable chunks only - and byte size, each
 * predicted from the previous chunk's) lets a reader start at any chunk:
 * seeking by point index decodes from the start of the point's chunk.
 * Without a usable table chunks are read one after the other, where the
 * decoder of the previous one stopped (it reads exactly what the encoder
 * wrote), and seeking is unsupported.
 */
#include "io/format.h"
#include "io/las/las_internal.h"
#include "io/laz/laz.h"
#include "io/laz/laz_items.h"
#include "io/laz/laz_layered.h"
#include "io/record_cache.h"
#include "common/version.h"

#include <stdlib.h>
#include <string.h>

/* Buffer of the byte source: large enough that refills are rare, small
 * enough for one per reader thread. */
#define LAZ_IN_BUFFER (256u * 1024u)

typedef struct laz_reader {
    laz_in in;
    laz_dec dec;
    laz_items *items;           /* point-wise compressor, or */
    laz_layered *layered;       /* layered compressor (point formats 6-10) */
    uint8_t *scratch;           /* one record, for points skipped after a seek */
    uint32_t record_length;
    double scale[3], offset[3];
    uint64_t data_start;        /* first chunk */
    uint64_t data_end;          /* end of the chunks (the table, or the file end) */
    uint64_t chunk_points;      /* points per chunk (fixed chunks) */
    uint64_t nchunks;           /* chunks in the table; 0: no table */
    uint64_t *start;            /* [nchunks + 1] file offsets of the chunks */
    uint64_t *first;            /* [nchunks + 1] index of each chunk's first point */
    uint64_t next;              /* index of the next point decoded */
    uint64_t chunk;             /* chunk of the next point */
    uint64_t chunk_left;        /* points left in it; 0: the next point opens a chunk */
    uint64_t skip_to;           /* after a seek: points before this are decoded unseen */
    uint64_t marked;            /* with a cache: chunks before this that the decoder
                                   closed are marked complete (from a position on) */
    uint8_t *skipped;           /* with a cache: points decoded unseen, for the cache */
} laz_reader;

/* Skipped points decoded between two writes to the cache. */
#define LAZ_SKIP_RECORDS 1024u

/* ---- chunk table ---- */

/* Reads the i64 at off into *v. Returns 0, or -1 past the file's end. */
static int read_i64(wpd_reader *r, laz_reader *z, uint64_t off, int64_t *v)
{
    uint8_t b[8];
    if (off > r->hdr.file_size || r->hdr.file_size - off < 8)
        return -1;
    laz_in_seek(&z->in, off, off + 8);
    laz_in_bytes(&z->in, b, 8);
    if (z->in.overrun)
        return -1;
    memcpy(v, b, 8);
    return 0;
}

/* Points in chunk i of a table with fixed chunks. */
static uint64_t fixed_chunk_points(const wpd_reader *r, const laz_reader *z, uint64_t i)
{
    uint64_t before = i * z->chunk_points, count = r->hdr.point_count;
    return count - before < z->chunk_points ? count - before : z->chunk_points;
}

/* Decodes the table's entries (n chunks, its stream at off) into z->start
 * and z->first, and checks them: chunks end before the table, point counts
 * add up to the header's. Returns NULL, or why the table is unusable. */
static const char *decode_table(wpd_reader *r, laz_reader *z, uint64_t off, uint64_t table,
                                uint64_t n, int variable)
{
    laz_ic ic;
    if (laz_ic_create(&ic, 32, 2)) {
        laz_ic_free(&ic);
        return "out of memory";
    }
    laz_in_seek(&z->in, off, r->hdr.file_size);
    laz_dec_init(&z->dec, &z->in);
    uint32_t prev_count = 0, prev_size = 0;
    z->start[0] = z->data_start;
    z->first[0] = 0;
    const char *why = NULL;
    for (uint64_t i = 0; i < n && !why; i++) {
        uint32_t count = variable ? (uint32_t)laz_ic_decode(&ic, &z->dec, (int32_t)prev_count, 0)
                                  : (uint32_t)fixed_chunk_points(r, z, i);
        uint32_t size = (uint32_t)laz_ic_decode(&ic, &z->dec, (int32_t)prev_size, 1);
        prev_count = count, prev_size = size;
        z->start[i + 1] = z->start[i] + size;
        z->first[i + 1] = z->first[i] + count;
        if (!count || size < z->record_length || z->start[i + 1] > table)
            why = "its chunk sizes do not fit the point data";
        else if (z->first[i + 1] > r->hdr.point_count)
            why = "its point counts pass the header's";
    }
    laz_ic_free(&ic);
    if (!why && z->in.overrun)
        why = "it is truncated";
    if (!why && z->first[n] != r->hdr.point_count)
        why = "its point counts do not add up to the header's";
    /* Encoders write the table right after the last chunk. */
    if (!why && z->start[n] != table)
        why = "its chunk sizes do not add up to the point data";
    return why;
}

/* Finds, checks and decodes the chunk table. Returns NULL with z->nchunks
 * set and *table_end at the first byte after the table, or why it cannot
 * be used (then nothing is kept). */
static const char *read_chunk_table(wpd_reader *r, laz_reader *z, uint64_t *table_end)
{
    const wpd_las_info *l = &r->hdr.las;
    int64_t at;
    if (read_i64(r, z, l->offset_to_points, &at))
        return "the point data end before its offset";
    if (at == -1 && read_i64(r, z, r->hdr.file_size - 8, &at))
        return "its offset is missing at the end of the file";
    uint8_t head[8];
    if (at < (int64_t)z->data_start || (uint64_t)at > r->hdr.file_size - 8)
        return "its offset is not in the file after the point data";
    laz_in_seek(&z->in, (uint64_t)at, (uint64_t)at + 8);
    laz_in_bytes(&z->in, head, 8);
    if (las_get_u32(head) != 0)
        return "its version is not 0";
    uint64_t n = las_get_u32(head + 4), table = (uint64_t)at;
    int variable = l->laz.chunk_size == UINT32_MAX || l->laz.chunk_size == 0;
    /* Each chunk holds at least one point and its raw record: this bounds
     * n by the file before anything is allocated. */
    if (!n || n > r->hdr.point_count || n > (table - z->data_start) / z->record_length)
        return "its chunk count does not fit the file";
    if (!variable && n != (r->hdr.point_count + z->chunk_points - 1) / z->chunk_points)
        return "its chunk count does not match the point count";
    z->start = malloc((n + 1) * sizeof *z->start);
    z->first = malloc((n + 1) * sizeof *z->first);
    if (!z->start || !z->first)
        return "out of memory";
    const char *why = decode_table(r, z, table + 8, table, n, variable);
    if (why)
        return why;
    z->nchunks = n;
    z->data_end = table;
    *table_end = laz_in_tell(&z->in);
    return NULL;
}

/* ---- decoding ---- */

static int fail_chunk(wpd_reader *r, laz_reader *z, const char *what, wpd_error *err)
{
    if (z->in.io_errno)
        return wpd_fail(err, WPD_E_IO, "%s: cannot read the LAZ point data: %s", r->hdr.path,
                        strerror(z->in.io_errno));
    return wpd_fail(err, WPD_E_INPUT, "%s: LAZ chunk %llu (points from %llu): %s", r->hdr.path,
                    (unsigned long long)z->chunk,
                    (unsigned long long)(z->nchunks ? z->first[z->chunk]
                                                    : z->chunk * z->chunk_points),
                    what);
}

/* Opens a layered chunk: its point count must be the table's, or without
 * a table at least 1 and no more than the points left. */
static int open_layered(wpd_reader *r, laz_reader *z, uint8_t *rec, wpd_error *err)
{
    const char *why = NULL;
    uint64_t limit = z->nchunks ? z->start[z->chunk + 1] : z->data_end;
    uint32_t count;
    int rc = laz_layered_open(z->layered, &z->in, limit, z->record_length, rec, &count, &why);
    uint64_t table_count = z->chunk_left;
    z->chunk_left = 0; /* until it opened: a read after a failure opens it again */
    if (rc == -2)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a LAZ chunk", r->hdr.path);
    if (rc)
        return fail_chunk(r, z, why, err);
    uint64_t left = r->hdr.point_count - z->next;
    if (z->nchunks ? count != table_count : (!count || count > left))
        return fail_chunk(r, z, "its point count does not match the chunk table or header", err);
    z->chunk_left = count;
    return 0;
}

/* Opens chunk z->chunk: its raw first record into rec, then the decoder. */
static int open_chunk(wpd_reader *r, laz_reader *z, uint8_t *rec, wpd_error *err)
{
    if (z->nchunks) {
        uint64_t c = z->chunk;
        laz_in_seek(&z->in, z->start[c], z->start[c + 1]);
        z->chunk_left = z->first[c + 1] - z->first[c];
    } else {
        uint64_t left = r->hdr.point_count - z->next;
        z->chunk_left = left < z->chunk_points ? left : z->chunk_points;
    }
    if (z->layered)
        return open_layered(r, z, rec, err);
    laz_in_bytes(&z->in, rec, z->record_length);
    laz_dec_init(&z->dec, &z->in);
    if (z->in.overrun)
        return fail_chunk(r, z, "the data end inside the chunk (file truncated?)", err);
    laz_items_start(z->items, rec);
    return 0;
}

/* Ends the current chunk: a valid stream ends exactly where the table says
 * the next chunk starts, and never needs bytes past it. */
static int close_chunk(wpd_reader *r, laz_reader *z, wpd_error *err)
{
    if (z->in.overrun)
        return fail_chunk(r, z, "the compressed stream runs past the chunk's end (truncated "
                                "or corrupt)", err);
    const char *why = z->layered ? laz_layered_close(z->layered) : NULL;
    if (why)
        return fail_chunk(r, z, why, err);
    if (z->nchunks && laz_in_tell(&z->in) != z->start[z->chunk + 1])
        return fail_chunk(r, z, "the compressed stream does not end where the chunk ends "
                                "(corrupt)", err);
    z->chunk++;
    return 0;
}

/* Decodes the next point into rec. */
static int next_point(wpd_reader *r, laz_reader *z, uint8_t *rec, wpd_error *err)
{
    if (!z->chunk_left) {
        if (open_chunk(r, z, rec, err))
            return -1;
    } else {
        const char *why = NULL;
        int rc = z->layered ? laz_layered_decode(z->layered, rec, &why)
                            : laz_items_decode(z->items, &z->dec, rec, &why);
        if (rc == -2)
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a LAZ model", r->hdr.path);
        if (rc)
            return fail_chunk(r, z, why, err);
    }
    z->next++;
    if (--z->chunk_left == 0)
        return close_chunk(r, z, err);
    return 0;
}

/* Decodes n points into rec (n records). */
static int decode_points(wpd_reader *r, laz_reader *z, uint8_t *rec, size_t n, wpd_error *err)
{
    for (size_t i = 0; i < n; i++)
        if (next_point(r, z, rec + i * z->record_length, err))
            return -1;
    if (z->in.overrun || z->in.io_errno)
        return fail_chunk(r, z, "the data end inside the chunk (file truncated?)", err);
    return 0;
}

/* The decoder goes to the start of index's chunk; the points before index
 * in it are decoded unseen by the next read that decodes. */
static void position(wpd_reader *r, laz_reader *z, uint64_t index)
{
    if (index >= r->hdr.point_count) { /* nothing to decode */
        z->next = z->skip_to = index;
        z->chunk_left = 0;
        return;
    }
    z->chunk = wpd_chunk_holding(z->first, z->nchunks, index);
    z->chunk_left = 0;
    z->next = z->first[z->chunk];
    z->skip_to = index;
    z->marked = z->chunk;
}

/* n records decoded from index on go to the cache; the chunks the decoder
 * closed since the last call are then complete (it decodes a chunk from
 * its first point, and every point it decodes is written). */
static int keep_decoded(wpd_reader *r, laz_reader *z, uint64_t index, const uint8_t *rec,
                        size_t n, wpd_error *err)
{
    if (wpd_record_cache_write(r->cache, index, rec, n, err))
        return -1;
    for (; z->marked < z->chunk; z->marked++)
        wpd_record_cache_complete(r->cache, z->marked);
    return 0;
}

/* Decodes the points before z->skip_to unseen (into the cache, if any). */
static int skip_points(wpd_reader *r, laz_reader *z, wpd_error *err)
{
    while (z->next < z->skip_to) {
        if (!r->cache) {
            if (next_point(r, z, z->scratch, err))
                return -1;
            continue;
        }
        uint64_t from = z->next, left = z->skip_to - from;
        size_t n = left < LAZ_SKIP_RECORDS ? (size_t)left : LAZ_SKIP_RECORDS;
        if (!z->skipped && !(z->skipped = malloc((size_t)LAZ_SKIP_RECORDS * z->record_length)))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
        if (decode_points(r, z, z->skipped, n, err) ||
            keep_decoded(r, z, from, z->skipped, n, err))
            return -1;
    }
    return 0;
}

/* Records from the cache where it holds them: the longest prefix of the n
 * from index on that lies in complete chunks. Returns how many were read
 * (0: none held), or -1 with err set. */
static long read_cached(wpd_reader *r, laz_reader *z, uint64_t index, size_t n, uint8_t *dst,
                        wpd_error *err)
{
    size_t held = r->cache ? wpd_record_cache_held(r->cache, index, n) : 0;
    if (held == 0)
        return 0;
    if (wpd_record_cache_read(r->cache, index, dst, held, err))
        return -1;
    position(r, z, index + held);
    return (long)held;
}

static long laz_read(wpd_reader *r, wpd_batch *b, wpd_error *err)
{
    laz_reader *z = r->impl;
    const uint32_t len = z->record_length;
    size_t kept = 0;
    b->n = 0;
    if (!b->cap)
        return wpd_fail(err, WPD_E_USAGE, "%s: read into a batch without room", r->hdr.path);
    /* Loop until something is kept, so that 0 means only "end of points". */
    for (;;) {
        uint64_t at = z->next > z->skip_to ? z->next : z->skip_to;
        if (kept || at >= r->end)
            break;
        uint64_t left = r->end - at;
        size_t want = b->cap < left ? b->cap : (size_t)left;
        uint8_t *dst = b->records;
        long got = read_cached(r, z, at, want, dst, err);
        if (got < 0)
            return -1;
        if (got == 0) {
            if (skip_points(r, z, err) || decode_points(r, z, dst, want, err) ||
                (r->cache && keep_decoded(r, z, at, dst, want, err)))
                return -1;
            got = (long)want;
        }
        kept = las_decode_xyz(z->scale, z->offset, len, dst, (size_t)got, b->xyz);
        r->dropped += (size_t)got - kept;
    }
    b->n = kept;
    return (long)kept;
}

/* Positions at the chunk holding index; the points before index in it are
 * decoded (and dropped) by the next read, unless the cache holds them. */
static int laz_seek(wpd_reader *r, uint64_t index, wpd_error *err)
{
    (void)err;
    position(r, r->impl, index);
    return 0;
}

static void laz_close(wpd_reader *r)
{
    laz_reader *z = r->impl;
    if (!z)
        return;
    laz_in_free(&z->in);
    laz_items_free(z->items);
    laz_layered_free(z->layered);
    free(z->scratch);
    free(z->skipped);
    free(z->start);
    free(z->first);
    free(z);
    r->impl = NULL;
}

/* Layered chunks: from the next chunk on, only the X Y and Z layers. */
static int laz_positions_only(wpd_reader *r, int on)
{
    laz_reader *z = r->impl;
    if (!z->layered)
        return 0;
    laz_layered_xyz_only(z->layered, on);
    return 1;
}

/* A cache of the decoded records, for files that can be positioned. */
static int laz_new_cache(wpd_reader *r, const char *dir, int id, wpd_record_cache **out,
                         wpd_error *err)
{
    laz_reader *z = r->impl;
    *out = wpd_record_cache_create(dir, id, r->hdr.path, z->record_length, z->first,
                                   z->nchunks, err);
    return *out ? 0 : -1;
}

static uint64_t laz_chunks(const wpd_reader *r, const uint64_t **first)
{
    const laz_reader *z = r->impl;
    *first = z->first;
    return z->nchunks;
}

static const wpd_reader_ops laz_ops_seek = {laz_read, laz_seek, laz_close, laz_positions_only,
                                            laz_new_cache, laz_chunks};
static const wpd_reader_ops laz_ops_sequential = {laz_read, NULL, laz_close,
                                                  laz_positions_only, NULL, NULL};

/* ---- opening ---- */

/* A layered file that wpd wrote before 0.2.0 (generating software "wpd"
 * alone and wpd's LASzip VLR) with colour, NIR or extra bytes: those items
 * then took the point's scanner channel as their context, where LASzip's
 * rule (and this reader) takes the new channel on a point that changes
 * channel and context 0 on the others. The two agree while a chunk keeps
 * one channel (a context that only the raw first point set starts another
 * unchanged), and POINT14 itself was right: only files with such items
 * whose points change channel within a chunk read wrong. */
static int old_wpd_layered(const wpd_reader *r)
{
    const wpd_las_info *l = &r->hdr.las;
    /* Those versions always wrote chunks of WPD_LAZ_CHUNK_POINTS: that also
     * bounds what the check below decodes. */
    if (l->laz.compressor != 3 || !l->laz.wpd_vlr || strcmp(l->software, WPD_SOFTWARE_OLD) ||
        l->laz.chunk_size != WPD_LAZ_CHUNK_POINTS)
        return 0;
    for (uint16_t i = 0; i < l->laz.nitems; i++)
        if (l->laz.items[i].type != LAZ_ITEM_POINT14)
            return 1;
    return 0;
}

/* For old_wpd_layered files: decodes the first chunk's X, Y and Z (the
 * scanner channel is coded with them) and warns, in one line, when its
 * points change channel. Only the first chunk is looked at, so that an
 * open costs one chunk at most; multi-channel scanners interleave their
 * channels throughout a file. The reader is then back at the first point,
 * every layer wanted; a damaged chunk is left for the read to report. */
static void check_old_wpd(wpd_reader *r, laz_reader *z)
{
    if (!old_wpd_layered(r) || !r->hdr.point_count)
        return;
    wpd_error ignored;
    unsigned channels = 0;
    laz_layered_xyz_only(z->layered, 1);
    while (z->chunk == 0 && z->next < r->hdr.point_count && z->next < WPD_LAZ_CHUNK_POINTS &&
           channels < 2 &&
           next_point(r, z, z->scratch, &ignored) == 0) {
        unsigned used = laz_layered_channels(z->layered);
        channels = (used & 1) + (used >> 1 & 1) + (used >> 2 & 1) + (used >> 3 & 1);
    }
    laz_layered_xyz_only(z->layered, 0);
    z->chunk = z->chunk_left = z->next = z->skip_to = z->marked = 0;
    laz_in_seek(&z->in, z->data_start, z->data_end);
    if (channels > 1)
        wpd_warn(&r->hdr.warnings,
                 "%s: written by an older wpd with a known LAZ scanner channel bug (its "
                 "points change channel within a chunk: colour, NIR and extra bytes decode "
                 "wrong or not at all); re-create the file from its source",
                 r->hdr.path);
}

/* Chunk table, or the sequential fallback with a warning; variable chunks
 * cannot be found without the table. Sets *points_end. */
static int find_chunks(wpd_reader *r, laz_reader *z, uint64_t *points_end, wpd_error *err)
{
    const wpd_las_info *l = &r->hdr.las;
    z->data_end = r->hdr.file_size;
    *points_end = z->data_start;
    if (l->laz.compressor == 1) { /* one chunk of every point, no table */
        z->chunk_points = r->hdr.point_count;
        return 0;
    }
    int variable = l->laz.chunk_size == UINT32_MAX || l->laz.chunk_size == 0;
    z->chunk_points = variable ? 0 : l->laz.chunk_size;
    const char *why = read_chunk_table(r, z, points_end);
    if (!why) {
        r->ops = &laz_ops_seek;
        r->hdr.las.laz.chunks = z->nchunks;
        return 0;
    }
    free(z->start), free(z->first);
    z->start = z->first = NULL;
    /* Layered chunks store their point count: they can be walked. */
    if (variable && l->laz.compressor != 3)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: LAZ with variable-size chunks needs its chunk table, and it is "
                        "unusable: %s",
                        r->hdr.path, why);
    wpd_warn(&r->hdr.warnings,
             "%s: the LAZ chunk table is unusable (%s); points are read sequentially and "
             "the file cannot be read from a point index",
             r->hdr.path, why);
    return 0;
}

int wpd_laz_open_reader(wpd_reader *r, uint64_t *points_end, wpd_error *err)
{
    const wpd_las_info *l = &r->hdr.las;
    if (wpd_laz_check(&r->hdr, err))
        return -1;
    laz_reader *z = calloc(1, sizeof *z);
    if (!z)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    r->impl = z;
    r->ops = &laz_ops_sequential;
    z->record_length = l->record_length;
    memcpy(z->scale, l->scale, sizeof z->scale);
    memcpy(z->offset, l->offset, sizeof z->offset);
    int layered = l->laz.compressor == 3;
    if (laz_in_init(&z->in, r->fd, LAZ_IN_BUFFER) || !(z->scratch = malloc(l->record_length)) ||
        (layered ? !(z->layered = laz_layered_create(l->laz.items, l->laz.nitems))
                 : !(z->items = laz_items_create(l->laz.items, l->laz.nitems))))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    /* Compressor 1 (LASzip 1.x) has no chunk table offset before the data. */
    z->data_start = l->offset_to_points + (l->laz.compressor == 1 ? 0 : 8);
    *points_end = z->data_start;
    if (!r->hdr.point_count)
        return 0;
    if (z->data_start > r->hdr.file_size)
        return wpd_fail(err, WPD_E_INPUT, "%s: the LAZ point data end before they start",
                        r->hdr.path);
    if (find_chunks(r, z, points_end, err))
        return -1;
    laz_in_seek(&z->in, z->data_start, z->data_end);
    check_old_wpd(r, z);
    return 0;
}
