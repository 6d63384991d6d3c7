/* ply_write.c - streaming writer for PLY files (binary little-endian, or
 * ascii with w->opt.ply_ascii).
 *
 * Only a "vertex" element is written: one property per schema dimension, in
 * dimension order, packed without gaps. The vertex count is known only at
 * the end, so the header reserves room for it: the line before
 * "element vertex N" is a blank comment padded with spaces so that the two
 * lines together always take the same number of bytes, and finish() rewrites
 * them in place. The padding comment keeps at least one space after the
 * keyword so that readers which take the rest of the line after
 * "comment " (rply and friends) never swallow the element line.
 */
#include "io/format.h"
#include "io/ply/ply_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLY_OUT_BUF (2u << 20)   /* output assembled in blocks of this size */
#define PLY_ASCII_VALUE_MAX 32   /* longest formatted value plus separator */

typedef struct ply_writer {
    uint32_t ndims;
    wpd_dim out[WPD_MAX_DIMS];     /* output layout: dims in order, packed */
    uint32_t src_offset[WPD_MAX_DIMS];
    uint32_t out_size;             /* bytes per output record */
    int direct;                    /* input records already have the output layout */
    int cx, cy, cz;                /* coordinate dims (cz -1 when absent) */
    uint8_t *scratch;              /* one output record (ascii path) */
    char *buf;
    size_t len, cap;
    long long patch_offset;        /* where the padding comment starts */
} ply_writer;

static const char *const encoding_names[] = WPD_PLY_ENCODING_NAMES;

/* ------------------------------------------------------------------ header text */

typedef struct text {
    char *s;
    size_t len, cap;
    int failed;
} text;

static void text_printf(text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void text_printf(text *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(t->s ? t->s + t->len : NULL, t->s ? t->cap - t->len : 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            t->failed = 1;
            return;
        }
        if (t->s && t->len + (size_t)n < t->cap) {
            t->len += (size_t)n;
            return;
        }
        size_t cap = t->cap ? t->cap * 2 : 4096;
        while (cap <= t->len + (size_t)n)
            cap *= 2;
        char *grown = realloc(t->s, cap);
        if (!grown) {
            t->failed = 1;
            return;
        }
        t->s = grown;
        t->cap = cap;
    }
}

/* Appends one comment or obj_info line; line breaks inside the text would
 * end the header line early, so they become spaces. */
static void text_keyword_line(text *t, const char *keyword, const char *s)
{
    size_t start = t->len;
    text_printf(t, "%s %s\n", keyword, s);
    if (t->failed)
        return;
    for (size_t i = start; i + 1 < t->len; i++)
        if (t->s[i] == '\n' || t->s[i] == '\r')
            t->s[i] = ' ';
}

static int is_blank(const char *s)
{
    return s[strspn(s, " \t\r\n")] == '\0';
}

/* The padding comment and the element line for count: always the same
 * length (see the file comment). Returns the length written to out. */
static int count_lines(char *out, size_t size, uint64_t count)
{
    char digits[24];
    int nd = snprintf(digits, sizeof digits, "%llu", (unsigned long long)count);
    int pad = 1 + WPD_PLY_COUNT_DIGITS - nd;
    return snprintf(out, size, "comment%*s\nelement vertex %s\n", pad, "", digits);
}

/* A property name must be one header word. */
static int valid_name(const char *s)
{
    if (!*s)
        return 0;
    for (; *s; s++)
        if ((unsigned char)*s <= ' ' || (unsigned char)*s >= 127)
            return 0;
    return 1;
}

static int write_header(wpd_writer *w, ply_writer *pw, wpd_error *err)
{
    const wpd_ply_info *info = &w->hdr.ply;
    text t = {0};
    text_printf(&t, "ply\nformat %s 1.0\n",
                encoding_names[w->opt.ply_ascii ? WPD_PLY_ASCII : WPD_PLY_BINARY_LE]);
    for (uint32_t i = 0; info->comments && i < info->ncomments; i++)
        if (!is_blank(info->comments[i])) /* blank ones include an earlier padding line */
            text_keyword_line(&t, "comment", info->comments[i]);
    for (uint32_t i = 0; info->obj_info && i < info->nobj_info; i++)
        text_keyword_line(&t, "obj_info", info->obj_info[i]);
    pw->patch_offset = (long long)t.len;
    char lines[96];
    count_lines(lines, sizeof lines, 0);
    text_printf(&t, "%s", lines);
    for (uint32_t k = 0; k < pw->ndims; k++)
        text_printf(&t, "property %s %s\n", wpd_type_name(pw->out[k].type), pw->out[k].name);
    text_printf(&t, "end_header\n");
    int rc = t.failed ? wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", w->out.final_path)
                      : wpd_outfile_write(&w->out, t.s, t.len, err);
    free(t.s);
    return rc;
}

/* ------------------------------------------------------------------ layout */

/* Checks the schema and derives the packed output layout. */
static int plan_layout(wpd_writer *w, ply_writer *pw, wpd_error *err)
{
    const wpd_schema *s = &w->hdr.schema;
    const char *path = w->out.final_path;
    if (s->dim_x < 0 || s->dim_y < 0 || (uint32_t)s->dim_x >= s->ndims ||
        (uint32_t)s->dim_y >= s->ndims || s->dim_z >= (int)s->ndims)
        return wpd_fail(err, WPD_E_USAGE, "%s: PLY output needs x and y dimensions", path);
    uint32_t offset = 0;
    pw->direct = 1;
    for (uint32_t k = 0; k < s->ndims; k++) {
        const wpd_dim *d = &s->dims[k];
        uint32_t size = (uint32_t)wpd_type_size(d->type);
        if (d->bit_count || d->scaled)
            return wpd_fail(err, WPD_E_USAGE,
                            "%s: dimension '%s' is a bit field or scaled; PLY output needs "
                            "plain dimensions", path, d->name);
        if ((uint64_t)d->offset + size > s->record_size)
            return wpd_fail(err, WPD_E_USAGE, "%s: dimension '%s' lies outside the %u-byte record",
                            path, d->name, s->record_size);
        if (!valid_name(d->name))
            return wpd_fail(err, WPD_E_USAGE, "%s: '%s' is not a valid PLY property name", path,
                            d->name);
        pw->out[k] = *d;
        pw->out[k].offset = offset;
        pw->src_offset[k] = d->offset;
        pw->direct &= d->offset == offset;
        offset += size;
    }
    pw->ndims = s->ndims;
    pw->out_size = offset;
    pw->direct &= offset == s->record_size;
    pw->cx = s->dim_x;
    pw->cy = s->dim_y;
    pw->cz = s->dim_z;
    return 0;
}

/* ------------------------------------------------------------------ records */

static int flush(wpd_writer *w, ply_writer *pw, wpd_error *err)
{
    if (pw->len && wpd_outfile_write(&w->out, pw->buf, pw->len, err))
        return -1;
    pw->len = 0;
    return 0;
}

static inline void store_coord(const wpd_dim *d, uint8_t *rec, double v)
{
    if (d->type == WPD_F64) {
        memcpy(rec + d->offset, &v, 8);
    } else if (d->type == WPD_F32) {
        float f = (float)v;
        memcpy(rec + d->offset, &f, 4);
    } else {
        wpd_dim_set(d, rec, v);
    }
}

static inline void store_xyz(const ply_writer *pw, uint8_t *rec, const double *xyz)
{
    store_coord(&pw->out[pw->cx], rec, xyz[0]);
    store_coord(&pw->out[pw->cy], rec, xyz[1]);
    if (pw->cz >= 0)
        store_coord(&pw->out[pw->cz], rec, xyz[2]);
}

/* Builds the output record of one input record (packed, xyz stored). */
static inline void pack_record(const ply_writer *pw, const uint8_t *src, const double *xyz,
                               uint8_t *dst)
{
    if (pw->direct) {
        memcpy(dst, src, pw->out_size);
    } else {
        for (uint32_t k = 0; k < pw->ndims; k++)
            memcpy(dst + pw->out[k].offset, src + pw->src_offset[k],
                   wpd_type_size(pw->out[k].type));
    }
    store_xyz(pw, dst, xyz);
}

static int write_binary(wpd_writer *w, ply_writer *pw, const wpd_batch *b, wpd_error *err)
{
    const size_t rs = b->record_size, os = pw->out_size;
    for (size_t i = 0; i < b->n;) {
        if (pw->cap - pw->len < os && flush(w, pw, err))
            return -1;
        size_t m = (pw->cap - pw->len) / os;
        if (m > b->n - i)
            m = b->n - i;
        uint8_t *dst = (uint8_t *)pw->buf + pw->len;
        if (pw->direct) { /* one copy of the block, then the coordinates */
            memcpy(dst, b->records + i * rs, m * os);
            for (size_t j = 0; j < m; j++)
                store_xyz(pw, dst + j * os, b->xyz + 3 * (i + j));
        } else {
            for (size_t j = 0; j < m; j++)
                pack_record(pw, b->records + (i + j) * rs, b->xyz + 3 * (i + j), dst + j * os);
        }
        pw->len += m * os;
        i += m;
    }
    return 0;
}

/* Formats an integer exactly; returns the characters written. */
static size_t format_int(char *out, int64_t v, int is_unsigned, uint64_t uv)
{
    char tmp[24];
    size_t n = 0;
    uint64_t mag = is_unsigned ? uv : v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    do {
        tmp[n++] = (char)('0' + mag % 10);
        mag /= 10;
    } while (mag);
    size_t len = 0;
    if (!is_unsigned && v < 0)
        out[len++] = '-';
    while (n)
        out[len++] = tmp[--n];
    return len;
}

/* Shortest "%.Ng" form of v, N from min_digits up to max_digits, that reads
 * back as the same value (as float when is_float). Short forms keep ascii
 * files small and let readers take the exact fast path of their number
 * parser; max_digits (9 for float, 17 for double) always round-trips. */
static size_t format_shortest(char *out, double v, int min_digits, int max_digits, int is_float)
{
    size_t len = 0;
    for (int digits = min_digits; digits <= max_digits; digits++) {
        len = (size_t)snprintf(out, PLY_ASCII_VALUE_MAX, "%.*g", digits, v);
        double back = strtod(out, NULL);
        if (is_float ? (float)back == (float)v : back == v)
            break;
    }
    return len;
}

/* Formats field d of a packed record: integers exact, floating point in the
 * shortest form that round-trips exactly (NaN and inf as printf writes them). */
static size_t format_value(char *out, const wpd_dim *d, const uint8_t *rec)
{
    const uint8_t *p = rec + d->offset;
    switch (d->type) {
    case WPD_F32: { float v; memcpy(&v, p, 4); return format_shortest(out, v, 6, 9, 1); }
    case WPD_F64: { double v; memcpy(&v, p, 8); return format_shortest(out, v, 15, 17, 0); }
    case WPD_U8: case WPD_U16: case WPD_U32: case WPD_U64:
        return format_int(out, 0, 1, (uint64_t)wpd_value_get_int(d->type, p));
    default: return format_int(out, wpd_value_get_int(d->type, p), 0, 0);
    }
}

static int write_ascii(wpd_writer *w, ply_writer *pw, const wpd_batch *b, wpd_error *err)
{
    const size_t line_max = (size_t)pw->ndims * PLY_ASCII_VALUE_MAX + 1;
    for (size_t i = 0; i < b->n; i++) {
        if (pw->cap - pw->len < line_max && flush(w, pw, err))
            return -1;
        pack_record(pw, b->records + i * b->record_size, b->xyz + 3 * i, pw->scratch);
        char *out = pw->buf + pw->len;
        for (uint32_t k = 0; k < pw->ndims; k++) {
            out += format_value(out, &pw->out[k], pw->scratch);
            *out++ = k + 1 < pw->ndims ? ' ' : '\n';
        }
        pw->len = (size_t)(out - pw->buf);
    }
    return 0;
}

/* ------------------------------------------------------------------ operations */

static int ply_write(wpd_writer *w, const wpd_batch *b, wpd_error *err)
{
    ply_writer *pw = w->impl;
    int rc = w->opt.ply_ascii ? write_ascii(w, pw, b, err) : write_binary(w, pw, b, err);
    if (rc == 0)
        w->count += b->n;
    return rc;
}

static int ply_finish(wpd_writer *w, wpd_error *err)
{
    ply_writer *pw = w->impl;
    if (flush(w, pw, err))
        return -1;
    if (w->part) /* records only (writer.h) */
        return 0;
    char lines[96];
    int n = count_lines(lines, sizeof lines, w->count);
    return wpd_outfile_pwrite(&w->out, lines, (size_t)n, pw->patch_offset, err);
}

static void free_impl(ply_writer *pw)
{
    if (!pw)
        return;
    free(pw->buf);
    free(pw->scratch);
    free(pw);
}

static void ply_close_writer(wpd_writer *w)
{
    free_impl(w->impl);
    w->impl = NULL;
}

/* A part (writer.h): its records, written out; the count is generic. */
static int ply_end_part(wpd_writer *w, wpd_write_part *part, wpd_error *err)
{
    (void)part;
    return flush(w, w->impl, err);
}

static int ply_add_part(wpd_writer *w, const wpd_write_part *part, wpd_error *err)
{
    (void)w, (void)part, (void)err;
    return 0;
}

static const wpd_writer_ops ply_writer_ops = {ply_write, ply_finish, ply_close_writer,
                                              ply_end_part, ply_add_part};

int wpd_ply_open_writer(wpd_writer *w, wpd_error *err)
{
    ply_writer *pw = calloc(1, sizeof *pw);
    if (!pw)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", w->out.final_path);
    if (plan_layout(w, pw, err))
        goto fail;
    pw->cap = PLY_OUT_BUF;
    pw->buf = malloc(pw->cap);
    pw->scratch = malloc(pw->out_size);
    if (!pw->buf || !pw->scratch) {
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", w->out.final_path);
        goto fail;
    }
    if (!w->part && write_header(w, pw, err))
        goto fail;
    w->impl = pw;
    w->ops = &ply_writer_ops;
    return 0;
fail:
    free_impl(pw);
    return -1;
}
