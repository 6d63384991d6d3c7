/* ply_read.c - streaming reader for PLY files (ascii, binary little- and
 * big-endian).
 *
 * The header is parsed and checked against the file size when the reader is
 * opened. Only the "vertex" element is delivered: its scalar properties, in
 * file order, form a packed little-endian record (schema.h); vertex list
 * properties are skipped. Elements before the vertex element are skipped
 * (walked item by item when they hold lists); elements after it are never
 * read.
 *
 * Reading paths, fastest first:
 *   binary, vertex without lists: pread straight into the batch's records in
 *     blocks of about 1 MiB, byte-swap in place for big-endian files, then a
 *     tight loop decodes x y z and drops non-finite points. Seekable.
 *   binary, vertex with lists: item by item through a private buffer.
 *   ascii: whitespace-separated tokens through a private buffer, numbers
 *     parsed by an exact fast path with strtod as the fallback.
 *
 * The header is ply_header.c, the buffered view ply_stream.c, the number
 * parser decimal.c; this file walks and decodes the body.
 */
#include "io/ply/ply_reader.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/fullio.h"
#include "common/warnings.h"
#include "io/decimal.h"

#define PLY_CHUNK_BYTES (1u << 20)  /* records read and decoded at a time */

/* A list count of type t in file byte order. -1 for a uint64 count above
 * INT64_MAX: no file holds that many items, and callers treat it as a
 * negative count. */
static int64_t read_count(const uint8_t *p, wpd_type t, int big_endian)
{
    uint8_t tmp[8];
    size_t n = wpd_type_size(t);
    if (big_endian) {
        for (size_t i = 0; i < n; i++)
            tmp[i] = p[n - 1 - i];
        p = tmp;
    }
    int64_t v = wpd_value_get_int(t, p);
    return t == WPD_U64 && v < 0 ? -1 : v;
}

/* ------------------------------------------------------------------ locating */

/* Binary: skips one element's items starting at the stream position. */
static int skip_binary_element(wpd_reader *r, ply_reader *pr, const ply_elem *e,
                               wpd_error *err)
{
    ply_stream *s = &pr->st;
    int be = pr->enc == WPD_PLY_BINARY_BE;
    if (!e->has_lists) {
        uint64_t bytes = e->count * e->item_bytes; /* bounded by check_sizes */
        if (!ply_stream_skip(s, bytes))
            goto short_file;
        return 0;
    }
    for (uint64_t item = 0; item < e->count; item++) {
        for (uint32_t k = 0; k < e->nprops; k++) {
            const ply_prop *p = &pr->props[e->first_prop + k];
            if (!p->is_list) {
                if (!ply_stream_skip(s, wpd_type_size(p->type)))
                    goto short_item;
                continue;
            }
            size_t cs = wpd_type_size(p->count_type);
            int rc = ply_stream_need(s, cs, r->hdr.path, err);
            if (rc < 0)
                return -1;
            if (rc == 0)
                goto short_item;
            int64_t n = read_count((const uint8_t *)s->buf + s->pos, p->count_type, be);
            s->pos += cs;
            uint64_t bytes;
            if (n < 0)
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY element '%s' item %llu: negative list count",
                                r->hdr.path, e->name, (unsigned long long)item);
            if (__builtin_mul_overflow((uint64_t)n, wpd_type_size(p->type), &bytes) ||
                !ply_stream_skip(s, bytes))
                goto short_item;
            continue;
        short_item:
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: file ends inside PLY element '%s' (item %llu of %llu)",
                            r->hdr.path, e->name, (unsigned long long)item,
                            (unsigned long long)e->count);
        }
    }
    return 0;
short_file:
    return wpd_fail(err, WPD_E_INPUT, "%s: file ends inside PLY element '%s'", r->hdr.path,
                    e->name);
}

/* Ascii: the next token of the current item of element e. Each item is a
 * line of its own: its first token (first) must start a line after the
 * previous item's, the others must be on that line. Wrapped or run-together
 * items would otherwise shift every value after them without a trace (PCL
 * and plyfile refuse them too). Returns 1, -2 at end of file, -1 with err
 * set. */
static int item_token(ply_reader *pr, const ply_elem *e, uint64_t item, int first,
                      const char **tok, size_t *len, const char *path, wpd_error *err)
{
    int rc = ply_stream_token(&pr->st, tok, len, path, err);
    if (rc <= 0)
        return rc < 0 ? -1 : -2;
    uint64_t line = pr->st.token_line;
    if (first && line == pr->item_line)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: PLY line %llu holds more values than one item of element '%s' has "
                        "(each item must be a line of its own)",
                        path, (unsigned long long)line, e->name);
    if (first)
        pr->item_line = line;
    else if (line != pr->item_line)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: PLY line %llu: element '%s' item %llu has fewer values than its %u "
                        "properties need (it goes on at line %llu)",
                        path, (unsigned long long)pr->item_line, e->name,
                        (unsigned long long)item, e->nprops, (unsigned long long)line);
    return 1;
}

/* Ascii: skips the items of a list property whose count token is tok (the
 * count is checked before any item is read, so tok is still valid when it
 * is bad). Returns 1; 0 if tok is not a list count; -2 if the file ends
 * inside the list; -1 with err set. */
static int skip_ascii_list(ply_reader *pr, const ply_elem *e, uint64_t item, const char *tok,
                           size_t len, const char *path, wpd_error *err)
{
    uint64_t n;
    int neg;
    if (wpd_decimal_integer(tok, len, &neg, &n) != 1 || (neg && n))
        return 0;
    for (uint64_t j = 0; j < n; j++) {
        int rc = item_token(pr, e, item, 0, &tok, &len, path, err);
        if (rc <= 0)
            return rc;
    }
    return 1;
}

/* Ascii: the next token, for property k of item `item` of element e; a
 * list's items are skipped (*tok is then its count, valid only when it is
 * bad). Returns 1; 0 for a bad list count; -2 at end of file; -1 with err
 * set. */
static int next_ascii_value(ply_reader *pr, const ply_elem *e, uint64_t item, uint32_t k,
                            const char **tok, size_t *len, const char *path, wpd_error *err)
{
    int rc = item_token(pr, e, item, k == 0, tok, len, path, err);
    if (rc <= 0)
        return rc;
    return pr->props[e->first_prop + k].is_list
               ? skip_ascii_list(pr, e, item, *tok, *len, path, err)
               : 1;
}

/* Ascii: skips count items of an element (tokens; lists by their count). */
static int skip_ascii_element(wpd_reader *r, ply_reader *pr, const ply_elem *e, wpd_error *err)
{
    if (!e->nprops)
        return 0;
    for (uint64_t item = 0; item < e->count; item++) {
        for (uint32_t k = 0; k < e->nprops; k++) {
            const char *tok;
            size_t len;
            int rc = next_ascii_value(pr, e, item, k, &tok, &len, r->hdr.path, err);
            if (rc == -1)
                return -1;
            if (rc == -2)
                goto short_file;
            if (rc == 0)
                return wpd_fail(err, WPD_E_INPUT,
                                "%s: PLY element '%s' item %llu: bad list count '%.*s'",
                                r->hdr.path, e->name, (unsigned long long)item,
                                (int)(len > 40 ? 40 : len), tok);
        }
        continue;
    short_file:
        return wpd_fail(err, WPD_E_INPUT, "%s: file ends inside PLY element '%s' (item %llu of %llu)",
                        r->hdr.path, e->name, (unsigned long long)item,
                        (unsigned long long)e->count);
    }
    return 0;
}

/* Positions the stream at vertex 0 by skipping the elements before it. */
static int locate_vertices(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    ply_stream_seek(&pr->st, pr->body_offset);
    pr->st.line = pr->header_lines + 1;
    pr->item_line = pr->header_lines;
    for (uint32_t i = 0; i < pr->vertex; i++) {
        const ply_elem *e = &pr->elems[i];
        int rc = pr->enc == WPD_PLY_ASCII ? skip_ascii_element(r, pr, e, err)
                                          : skip_binary_element(r, pr, e, err);
        if (rc)
            return -1;
    }
    pr->vertex_offset = pr->st.file_pos - (pr->st.end - pr->st.pos);
    pr->located = 1;
    return 0;
}

/* Binary, once the vertices fit: as far as the header fixes where the
 * elements end (up to a list property), warns about a file that ends
 * inside an element after the vertices or, when it fixes the end of the
 * last one, about bytes after it. Neither changes the points: nothing
 * reads past the vertices (PCL warns about the second too). */
static void check_binary_end(wpd_reader *r, const ply_reader *pr)
{
    const uint64_t size = r->hdr.file_size;
    uint64_t end = pr->vertex_offset;
    for (uint32_t i = pr->vertex; i < pr->nelems; i++) {
        const ply_elem *e = &pr->elems[i];
        if (e->has_lists || ply_muladd_u64(e->count, e->item_bytes, end, &end))
            return;
        if (end > size) {
            wpd_warn(&r->hdr.warnings,
                     "%s: file ends %llu bytes short of the end of PLY element '%s'; the "
                     "vertices are complete and nothing after them is read",
                     r->hdr.path, (unsigned long long)(end - size), e->name);
            return;
        }
    }
    if (end < size)
        wpd_warn(&r->hdr.warnings,
                 "%s: %llu bytes after the last PLY element (which ends at offset %llu) belong "
                 "to no element; ignored",
                 r->hdr.path, (unsigned long long)(size - end), (unsigned long long)end);
}

/* Binary: finds vertex 0 now (so seeks work) and checks that the vertex data
 * fits in the rest of the file. */
static int locate_binary_vertices(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    const ply_elem *v = &pr->elems[pr->vertex];
    int lists_before = 0;
    uint64_t off = pr->body_offset;
    for (uint32_t i = 0; i < pr->vertex; i++) {
        lists_before |= pr->elems[i].has_lists;
        off += pr->elems[i].count * pr->elems[i].item_bytes; /* bounded by check_sizes */
    }
    if (lists_before) {
        if (locate_vertices(r, pr, err))
            return -1;
        off = pr->vertex_offset;
    } else {
        ply_stream_seek(&pr->st, off);
        pr->vertex_offset = off;
        pr->located = 1;
    }
    pr->fixed = !v->has_lists;
    if (pr->fixed) { /* direct reads from here on: the buffer is not needed */
        free(pr->st.buf);
        pr->st.buf = NULL;
    }
    uint64_t avail = r->hdr.file_size - off; /* off <= file size: checked or walked */
    uint64_t need = 0;
    if (ply_muladd_u64(v->count, v->item_bytes, 0, &need))
        need = UINT64_MAX;
    if (need > avail)
        return ply_fail_vertex_space(r, v, need, avail, off, err);
    check_binary_end(r, pr);
    return 0;
}

/* ------------------------------------------------------------------ decoding */

/* Keeps a decoded point: moves its record down to slot kept (when points
 * before it were dropped) and stores its coordinates. */
#define KEEP_OR_DROP(x, y, z)                                              \
    do {                                                                   \
        if (isfinite(x) && isfinite(y) && isfinite(z)) {                   \
            if (kept != i)                                                 \
                memcpy(rec + kept * rs, rec + i * rs, rs);                 \
            xyz[3 * kept] = (x);                                           \
            xyz[3 * kept + 1] = (y);                                       \
            xyz[3 * kept + 2] = (z);                                       \
            kept++;                                                        \
        }                                                                  \
    } while (0)

/* Decodes x y z of n packed records at rec into xyz, dropping the records
 * with a non-finite coordinate (the survivors are compacted to the front).
 * Returns the number kept. */
static size_t decode_points(const ply_reader *pr, uint8_t *rec, double *xyz, size_t n)
{
    const size_t rs = pr->record_size;
    const ply_coord *c = pr->coord;
    const uint32_t ox = c[0].offset, oy = c[1].offset, oz = c[2].offset;
    size_t kept = 0;
    if (c[2].present && c[0].type == WPD_F32 && c[1].type == WPD_F32 && c[2].type == WPD_F32) {
        for (size_t i = 0; i < n; i++) {
            const uint8_t *p = rec + i * rs;
            float fx, fy, fz;
            memcpy(&fx, p + ox, 4);
            memcpy(&fy, p + oy, 4);
            memcpy(&fz, p + oz, 4);
            KEEP_OR_DROP((double)fx, (double)fy, (double)fz);
        }
    } else if (c[2].present && c[0].type == WPD_F64 && c[1].type == WPD_F64 &&
               c[2].type == WPD_F64) {
        for (size_t i = 0; i < n; i++) {
            const uint8_t *p = rec + i * rs;
            double dx, dy, dz;
            memcpy(&dx, p + ox, 8);
            memcpy(&dy, p + oy, 8);
            memcpy(&dz, p + oz, 8);
            KEEP_OR_DROP(dx, dy, dz);
        }
    } else {
        for (size_t i = 0; i < n; i++) {
            const uint8_t *p = rec + i * rs;
            double dx = wpd_value_get(c[0].type, p + ox);
            double dy = wpd_value_get(c[1].type, p + oy);
            double dz = c[2].present ? wpd_value_get(c[2].type, p + oz) : 0.0;
            KEEP_OR_DROP(dx, dy, dz);
        }
    }
    return kept;
}

/* Big-endian files: converts n packed records to little-endian in place. */
static void swap_records(const ply_reader *pr, uint8_t *rec, size_t n)
{
    const size_t rs = pr->record_size;
    for (size_t i = 0; i < n; i++) {
        uint8_t *p = rec + i * rs;
        for (uint32_t k = 0; k < pr->nswap; k++) {
            uint8_t *f = p + pr->swap_offset[k];
            switch (pr->swap_size[k]) {
            case 2: { uint16_t v; memcpy(&v, f, 2); v = __builtin_bswap16(v); memcpy(f, &v, 2); break; }
            case 4: { uint32_t v; memcpy(&v, f, 4); v = __builtin_bswap32(v); memcpy(f, &v, 4); break; }
            default: { uint64_t v; memcpy(&v, f, 8); v = __builtin_bswap64(v); memcpy(f, &v, 8); break; }
            }
        }
    }
}

static int fail_truncated(const wpd_reader *r, uint64_t done, wpd_error *err)
{
    return wpd_fail(err, WPD_E_INPUT, "%s: file ends after %llu of %llu vertices", r->hdr.path,
                    (unsigned long long)done, (unsigned long long)r->hdr.point_count);
}

/* Binary, fixed-size records: n records straight from the file. */
static int read_fixed(wpd_reader *r, ply_reader *pr, uint8_t *rec, size_t n, wpd_error *err)
{
    size_t bytes = n * pr->record_size;
    ssize_t got = wpd_pread_full(r->fd, rec, bytes, pr->vertex_offset + pr->next * pr->record_size);
    if (got < 0)
        return wpd_fail_errno(err, "%s: cannot read", r->hdr.path);
    if ((size_t)got < bytes)
        return fail_truncated(r, pr->next + (size_t)got / pr->record_size, err);
    return 0;
}

/* Binary with vertex list properties: n records item by item, lists
 * skipped. Fields stay in file byte order. */
static int read_binary_items(wpd_reader *r, ply_reader *pr, uint8_t *rec, size_t n,
                             wpd_error *err)
{
    const ply_elem *v = &pr->elems[pr->vertex];
    ply_stream *s = &pr->st;
    int be = pr->enc == WPD_PLY_BINARY_BE;
    for (size_t i = 0; i < n; i++) {
        uint8_t *out = rec + i * pr->record_size;
        for (uint32_t k = 0; k < v->nprops; k++) {
            const ply_prop *p = &pr->props[v->first_prop + k];
            size_t size = wpd_type_size(p->is_list ? p->count_type : p->type);
            int rc = ply_stream_need(s, size, r->hdr.path, err);
            if (rc < 0)
                return -1;
            if (rc == 0)
                return fail_truncated(r, pr->next + i, err);
            const uint8_t *src = (const uint8_t *)s->buf + s->pos;
            s->pos += size;
            if (!p->is_list) {
                memcpy(out + p->offset, src, size);
                continue;
            }
            int64_t cnt = read_count(src, p->count_type, be);
            uint64_t bytes;
            if (cnt < 0)
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex %llu: negative list count",
                                r->hdr.path, (unsigned long long)(pr->next + i));
            if (__builtin_mul_overflow((uint64_t)cnt, wpd_type_size(p->type), &bytes) ||
                !ply_stream_skip(s, bytes))
                return fail_truncated(r, pr->next + i, err);
        }
    }
    return 0;
}

/* Ascii, after the last vertex: nothing more on its line. The next token,
 * if any, is on a later line: the next element's or bytes nothing reads. */
static int check_last_vertex_line(ply_reader *pr, const char *path, wpd_error *err)
{
    const char *tok;
    size_t len;
    int rc = ply_stream_token(&pr->st, &tok, &len, path, err);
    if (rc < 0)
        return -1;
    if (rc == 1 && pr->st.token_line == pr->item_line)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: PLY line %llu holds more values than one item of element 'vertex' has "
                        "(each item must be a line of its own)",
                        path, (unsigned long long)pr->item_line);
    return 0;
}

/* Ascii: parses n vertices into packed little-endian records. */
static int read_ascii_items(wpd_reader *r, ply_reader *pr, uint8_t *rec, size_t n,
                            wpd_error *err)
{
    const ply_elem *v = &pr->elems[pr->vertex];
    const ply_prop *props = pr->props + v->first_prop;
    for (size_t i = 0; i < n; i++) {
        uint8_t *out = rec + i * pr->record_size;
        for (uint32_t k = 0; k < v->nprops; k++) {
            const ply_prop *p = &props[k];
            const char *tok;
            size_t len;
            int rc = next_ascii_value(pr, v, pr->next + i, k, &tok, &len, r->hdr.path, err);
            if (rc == -1)
                return -1;
            if (rc == -2)
                return fail_truncated(r, pr->next + i, err);
            if (rc == 0)
                goto bad_value;
            if (p->is_list)
                continue;
            rc = wpd_decimal_field(tok, len, p->type, pr->c_locale, out + p->offset);
            if (rc == 0)
                continue;
            if (rc == -2)
                return wpd_fail(err, WPD_E_INPUT,
                                "%s: PLY vertex %llu property '%s': value '%.*s' out of range for %s",
                                r->hdr.path, (unsigned long long)(pr->next + i), p->name,
                                (int)(len > 40 ? 40 : len), tok, wpd_type_name(p->type));
        bad_value:
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: PLY vertex %llu property '%s': '%.*s' is not a valid %s",
                            r->hdr.path, (unsigned long long)(pr->next + i), p->name,
                            (int)(len > 40 ? 40 : len), tok,
                            p->is_list ? "list count" : wpd_type_name(p->type));
        }
    }
    return pr->next + n == pr->count ? check_last_vertex_line(pr, r->hdr.path, err) : 0;
}

/* ------------------------------------------------------------------ operations */

static long ply_read(wpd_reader *r, wpd_batch *b, wpd_error *err)
{
    ply_reader *pr = r->impl;
    b->n = 0;
    if (!pr->located && locate_vertices(r, pr, err))
        return -1;
    const size_t rs = pr->record_size;
    const size_t chunk = PLY_CHUNK_BYTES / rs ? PLY_CHUNK_BYTES / rs : 1;
    const uint64_t end = r->end < pr->count ? r->end : pr->count;
    while (b->n < b->cap && pr->next < end) {
        size_t n = b->cap - b->n;
        if (n > chunk)
            n = chunk;
        if (n > end - pr->next)
            n = (size_t)(end - pr->next);
        uint8_t *rec = b->records + b->n * rs;
        int rc = pr->fixed ? read_fixed(r, pr, rec, n, err)
                 : pr->enc == WPD_PLY_ASCII ? read_ascii_items(r, pr, rec, n, err)
                                            : read_binary_items(r, pr, rec, n, err);
        if (rc)
            return -1;
        if (pr->enc == WPD_PLY_BINARY_BE)
            swap_records(pr, rec, n);
        size_t kept = decode_points(pr, rec, b->xyz + 3 * b->n, n);
        r->dropped += n - kept;
        b->n += kept;
        pr->next += n;
    }
    return (long)b->n;
}

static int ply_seek(wpd_reader *r, uint64_t index, wpd_error *err)
{
    ply_reader *pr = r->impl;
    if (index > pr->count)
        return wpd_fail(err, WPD_E_USAGE, "%s: point index %llu past the end (%llu points)",
                        r->hdr.path, (unsigned long long)index, (unsigned long long)pr->count);
    pr->next = index;
    return 0;
}

static void free_impl(ply_reader *pr)
{
    if (!pr)
        return;
    if (pr->c_locale)
        freelocale(pr->c_locale);
    free(pr->st.buf);
    free(pr->elems);
    free(pr->props);
    free(pr);
}

static void ply_close(wpd_reader *r)
{
    free_impl(r->impl);
    r->impl = NULL;
}

static const wpd_reader_ops seekable_ops = {ply_read, ply_seek, ply_close, NULL, NULL, NULL};
static const wpd_reader_ops stream_ops = {ply_read, NULL, ply_close, NULL, NULL, NULL};

static int open_reader(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    const char *path = r->hdr.path;
    if (ply_read_header(r, pr, err))
        return -1;
    if (ply_stream_init(&pr->st, r->fd, r->hdr.file_size, pr->body_offset, err, path))
        return -1;
    if (pr->enc == WPD_PLY_ASCII) {
        pr->c_locale = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
        if (!pr->c_locale)
            return wpd_fail(err, WPD_E_MEMORY, "%s: cannot create the C locale", path);
        return 0;
    }
    return locate_binary_vertices(r, pr, err);
}

int wpd_ply_open_reader(wpd_reader *r, wpd_error *err)
{
    ply_reader *pr = calloc(1, sizeof *pr);
    if (!pr)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    if (open_reader(r, pr, err)) {
        free_impl(pr);
        return -1;
    }
    r->impl = pr;
    r->ops = pr->fixed ? &seekable_ops : &stream_ops;
    return 0;
}
