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
 */
#include "io/format.h"
#include "io/ply_internal.h"

#include <errno.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PLY_HEADER_MAX (1u << 20)   /* a longer header is refused */
#define PLY_HEADER_READ (64u << 10) /* header bytes read at a time */
#define PLY_LINE_MAX (16u << 10)    /* longest header line */
#define PLY_STREAM_BUF (1u << 20)   /* private buffer for ascii and skipping */
#define PLY_STREAM_MIN (4u << 10)   /* smallest one: > PLY_TOKEN_MAX + any item */
#define PLY_CHUNK_BYTES (1u << 20)  /* records read and decoded at a time */
#define PLY_TOKEN_MAX 1024          /* longest ascii token */
#define PLY_LINE_TOKENS 6           /* most tokens on a header line */

/* ------------------------------------------------------------------ state */

/* One property of one element. */
typedef struct ply_prop {
    char name[WPD_DIM_NAME_MAX]; /* truncated for messages when longer */
    wpd_type type;               /* scalar type, or the item type of a list */
    wpd_type count_type;         /* list count type */
    uint8_t is_list;
    uint32_t offset;             /* vertex scalars: offset in the packed record */
} ply_prop;

typedef struct ply_elem {
    char name[WPD_DIM_NAME_MAX];
    uint64_t count;
    uint32_t first_prop, nprops;
    int has_lists;
    uint64_t item_bytes;     /* binary: bytes per item, lists counted as empty */
} ply_elem;

/* A buffered view of the file from some offset, for ascii and for walking
 * binary items of varying size. buf has one byte beyond cap for a NUL
 * sentinel, so ascii scanning needs no bounds checks. */
typedef struct ply_stream {
    int fd;
    uint64_t file_size;
    char *buf;
    size_t cap, pos, end;    /* unread bytes are buf[pos..end) */
    uint64_t file_pos;       /* file offset of buf[end] */
    int eof;
} ply_stream;

/* Where and how a coordinate is stored in the packed record. */
typedef struct ply_coord {
    int present;
    wpd_type type;
    uint32_t offset;
} ply_coord;

typedef struct ply_reader {
    wpd_ply_encoding enc;
    ply_elem *elems;
    uint32_t nelems, vertex;
    ply_prop *props;
    uint32_t nprops, props_cap;
    uint32_t record_size;
    uint64_t count;          /* vertices */
    uint64_t body_offset;    /* first byte after end_header */
    uint64_t vertex_offset;  /* binary: file offset of vertex 0 */
    int located;             /* stream positioned at vertex 0 (or fixed) */
    int fixed;               /* binary records of fixed size: direct reads */
    uint64_t next;           /* index of the next vertex to read */
    ply_coord coord[3];
    uint32_t nswap;          /* big-endian: fields to byte-swap */
    uint16_t swap_offset[WPD_MAX_DIMS];
    uint8_t swap_size[WPD_MAX_DIMS];
    ply_stream st;
    locale_t c_locale;       /* ascii: strtod_l independent of setlocale */
} ply_reader;

static const char *const encoding_names[] = WPD_PLY_ENCODING_NAMES;

/* ------------------------------------------------------------------ small helpers */

static ssize_t pread_full(int fd, void *buf, size_t len, uint64_t off)
{
    size_t done = 0;
    while (done < len) {
        ssize_t n = pread(fd, (char *)buf + done, len - done, (off_t)(off + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -1;
        if (n == 0)
            break;
        done += (size_t)n;
    }
    return (ssize_t)done;
}

/* a * b + c without overflow; returns -1 on overflow. */
static int muladd_u64(uint64_t a, uint64_t b, uint64_t c, uint64_t *out)
{
    uint64_t p;
    if (__builtin_mul_overflow(a, b, &p) || __builtin_add_overflow(p, c, out))
        return -1;
    return 0;
}

static int is_int_type(wpd_type t) { return t != WPD_F32 && t != WPD_F64; }

/* Reads an integer of type t from a record field in file byte order. */
static int64_t read_int_field(const uint8_t *p, wpd_type t, int big_endian)
{
    uint8_t tmp[8];
    size_t n = wpd_type_size(t);
    if (big_endian) {
        for (size_t i = 0; i < n; i++)
            tmp[i] = p[n - 1 - i];
        p = tmp;
    }
    switch (t) {
    case WPD_I8: return (int8_t)p[0];
    case WPD_U8: return p[0];
    case WPD_I16: { int16_t v; memcpy(&v, p, 2); return v; }
    case WPD_U16: { uint16_t v; memcpy(&v, p, 2); return v; }
    case WPD_I32: { int32_t v; memcpy(&v, p, 4); return v; }
    case WPD_U32: { uint32_t v; memcpy(&v, p, 4); return v; }
    case WPD_I64: { int64_t v; memcpy(&v, p, 8); return v; }
    default: { uint64_t v; memcpy(&v, p, 8); return v > INT64_MAX ? -1 : (int64_t)v; }
    }
}

/* ------------------------------------------------------------------ stream */

/* The buffer holds the whole body when that is smaller than PLY_STREAM_BUF
 * (one byte more, so that the read which meets the end of the file fits
 * and sets eof): a small file does not cost a 1 MiB allocation. It is never
 * smaller than PLY_STREAM_MIN, so a full buffer always holds a whole token
 * or item even if the file grew after it was opened. */
static int stream_init(ply_stream *s, int fd, uint64_t file_size, uint64_t body_offset,
                       wpd_error *err, const char *path)
{
    s->fd = fd;
    s->file_size = file_size;
    uint64_t body = file_size > body_offset ? file_size - body_offset : 0;
    s->cap = body + 1 < PLY_STREAM_BUF ? (size_t)body + 1 : PLY_STREAM_BUF;
    if (s->cap < PLY_STREAM_MIN)
        s->cap = PLY_STREAM_MIN;
    s->buf = malloc(s->cap + 1);
    if (!s->buf)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
    s->pos = s->end = 0;
    s->buf[0] = '\0';
    return 0;
}

static void stream_seek(ply_stream *s, uint64_t off)
{
    s->pos = s->end = 0;
    s->buf[0] = '\0';
    s->file_pos = off;
    s->eof = off >= s->file_size;
}

/* Moves the unread bytes to the front of the buffer and reads more after
 * them. Returns the bytes added (0 at end of file or when the buffer is
 * full), or -1 with err set. */
static ssize_t stream_fill(ply_stream *s, const char *path, wpd_error *err)
{
    size_t keep = s->end - s->pos;
    if (s->pos) {
        memmove(s->buf, s->buf + s->pos, keep);
        s->pos = 0;
        s->end = keep;
    }
    ssize_t n = 0;
    if (!s->eof && s->end < s->cap) {
        do
            n = pread(s->fd, s->buf + s->end, s->cap - s->end, (off_t)s->file_pos);
        while (n < 0 && errno == EINTR);
        if (n < 0)
            return wpd_fail_errno(err, "%s: cannot read", path);
        if (n == 0)
            s->eof = 1;
        s->end += (size_t)n;
        s->file_pos += (uint64_t)n;
    }
    s->buf[s->end] = '\0';
    return n;
}

/* Makes at least k (<= cap) unread bytes available. Returns 1, 0 when the
 * file ends first, or -1 with err set. */
static int stream_need(ply_stream *s, size_t k, const char *path, wpd_error *err)
{
    while (s->end - s->pos < k) {
        if (s->eof)
            return 0;
        if (stream_fill(s, path, err) < 0)
            return -1;
    }
    return 1;
}

/* Skips n bytes. Returns 1, or 0 if that passes the end of the file. */
static int stream_skip(ply_stream *s, uint64_t n)
{
    size_t avail = s->end - s->pos;
    if (n <= avail) {
        s->pos += (size_t)n;
        return 1;
    }
    uint64_t off = s->file_pos + (n - avail);
    if (off < s->file_pos || off > s->file_size)
        return 0;
    stream_seek(s, off);
    return 1;
}

/* Which bytes separate ascii tokens. NUL is not a separator: it ends the
 * scan as the buffer sentinel. */
/* Whitespace lookup: a table load beats six comparisons in the hottest loop
 * of the ascii reader. */
static const uint8_t space_table[256] = {
    [' '] = 1, ['\n'] = 1, ['\r'] = 1, ['\t'] = 1, ['\v'] = 1, ['\f'] = 1,
};

static inline int is_space(unsigned char c) { return space_table[c]; }

/* Finds the next whitespace-separated token. Returns 1 with *tok and *len set
 * (the token is followed by a separator or the NUL sentinel), 0 at end of
 * file, -1 with err set. */
static int stream_token(ply_stream *s, const char **tok, size_t *len, const char *path,
                        wpd_error *err)
{
    for (;;) {
        char *p = s->buf + s->pos;
        while (is_space((unsigned char)*p))
            p++;
        char *q = p;
        while (*q && !is_space((unsigned char)*q))
            q++;
        char *end = s->buf + s->end;
        if (q < end) {
            if (!*q) /* a NUL inside the data, not the sentinel */
                return wpd_fail(err, WPD_E_INPUT, "%s: NUL byte in ascii PLY data at offset %llu",
                                path, (unsigned long long)(s->file_pos - (size_t)(end - q)));
            s->pos = (size_t)(q - s->buf);
            *tok = p;
            *len = (size_t)(q - p);
            return 1;
        }
        /* The scan reached the end of the buffered data: the token (if any)
         * may continue in the file. */
        s->pos = (size_t)(p - s->buf);
        if (s->eof) {
            if (q == p)
                return 0;
            *tok = p;
            *len = (size_t)(q - p);
            s->pos = s->end;
            return 1;
        }
        if ((size_t)(q - p) > PLY_TOKEN_MAX)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: ascii PLY token longer than %d bytes near offset %llu", path,
                            PLY_TOKEN_MAX, (unsigned long long)(s->file_pos - (size_t)(end - p)));
        if (stream_fill(s, path, err) < 0)
            return -1;
    }
}

/* ------------------------------------------------------------------ number parsing */

/* Exact powers of ten representable as doubles (Clinger's fast path). */
static const double exact_pow10[] = {
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
};

/* Parses a decimal number exactly when it has at most 15 significant digits
 * and a decimal exponent of at most 22 in magnitude: the digits are an exact
 * integer and one multiplication or division by an exact power of ten rounds
 * correctly. Returns 1 with *out set, 0 when the token needs strtod (other
 * syntax such as nan/inf, or more precision). */
static int parse_double_fast(const char *p, size_t len, double *out)
{
    const char *s = p, *end = p + len;
    int neg = 0;
    if (s < end && (*s == '-' || *s == '+'))
        neg = *s++ == '-';
    uint64_t mant = 0;
    int ndigits = 0, exp10 = 0, any = 0;
    while (s < end && *s == '0') {
        s++;
        any = 1;
    }
    while (s < end && (unsigned)(*s - '0') < 10) {
        if (ndigits >= 15)
            return 0;
        mant = mant * 10 + (unsigned)(*s++ - '0');
        ndigits++;
        any = 1;
    }
    if (s < end && *s == '.') {
        s++;
        if (!ndigits)
            while (s < end && *s == '0') {
                s++;
                exp10--;
                any = 1;
            }
        while (s < end && (unsigned)(*s - '0') < 10) {
            if (ndigits >= 15)
                return 0;
            mant = mant * 10 + (unsigned)(*s++ - '0');
            ndigits++;
            exp10--;
            any = 1;
        }
    }
    if (!any)
        return 0;
    if (s < end && (*s == 'e' || *s == 'E')) {
        s++;
        int eneg = 0, e = 0, edigits = 0;
        if (s < end && (*s == '-' || *s == '+'))
            eneg = *s++ == '-';
        while (s < end && (unsigned)(*s - '0') < 10) {
            if (e < 10000)
                e = e * 10 + (*s - '0');
            s++;
            edigits++;
        }
        if (!edigits)
            return 0;
        exp10 += eneg ? -e : e;
    }
    if (s != end)
        return 0;
    double v;
    if (mant == 0)
        v = 0.0;
    else if (exp10 < -22 || exp10 > 22)
        return 0;
    else
        v = exp10 < 0 ? (double)mant / exact_pow10[-exp10] : (double)mant * exact_pow10[exp10];
    *out = neg ? -v : v;
    return 1;
}

/* Parses a whole token as a double (nan, inf, hex and long forms via
 * strtod_l in the C locale). Returns 0, or -1 if the token is not a number. */
static int parse_double(const char *p, size_t len, locale_t loc, double *out)
{
    if (parse_double_fast(p, len, out))
        return 0;
    char copy[PLY_TOKEN_MAX + 1];
    if (len == 0 || len > PLY_TOKEN_MAX)
        return -1;
    memcpy(copy, p, len);
    copy[len] = '\0';
    char *end;
    *out = strtod_l(copy, &end, loc);
    return end == copy + len ? 0 : -1;
}

/* Parses an optionally signed run of decimal digits exactly. Returns 1 with
 * *neg and *mag set, 0 if the token is not a plain integer, -1 if it
 * overflows 64 bits. */
static int parse_integer(const char *p, size_t len, int *neg, uint64_t *mag)
{
    const char *s = p, *end = p + len;
    *neg = 0;
    if (s < end && (*s == '-' || *s == '+'))
        *neg = *s++ == '-';
    if (s == end)
        return 0;
    uint64_t v = 0;
    for (; s < end; s++) {
        unsigned d = (unsigned)(*s - '0');
        if (d >= 10)
            return 0;
        if (__builtin_mul_overflow(v, 10, &v) || __builtin_add_overflow(v, d, &v))
            return -1;
    }
    *mag = v;
    return 1;
}

static const int64_t int_min[] = {
    [WPD_I8] = INT8_MIN, [WPD_U8] = 0, [WPD_I16] = INT16_MIN, [WPD_U16] = 0,
    [WPD_I32] = INT32_MIN, [WPD_U32] = 0, [WPD_I64] = INT64_MIN, [WPD_U64] = 0,
};
static const uint64_t int_max[] = {
    [WPD_I8] = INT8_MAX, [WPD_U8] = UINT8_MAX, [WPD_I16] = INT16_MAX,
    [WPD_U16] = UINT16_MAX, [WPD_I32] = INT32_MAX, [WPD_U32] = UINT32_MAX,
    [WPD_I64] = INT64_MAX, [WPD_U64] = UINT64_MAX,
};

/* Parses an ascii value for an integer property. Plain integers are exact;
 * a token such as "3.0" or "1e2" is accepted when it is a whole number.
 * Returns 0 with *bits set to the two's-complement value, -1 if the token
 * is not a whole number, -2 if it is out of the type's range. */
static int parse_int_value(const char *p, size_t len, wpd_type t, locale_t loc,
                           uint64_t *bits)
{
    int neg;
    uint64_t mag;
    int rc = parse_integer(p, len, &neg, &mag);
    if (rc < 0)
        return -2;
    if (rc == 0) {
        double d;
        if (parse_double(p, len, loc, &d) || !isfinite(d) || d != floor(d))
            return -1;
        if (d < (double)int_min[t] || d > (double)int_max[t] || fabs(d) >= 18446744073709551616.0)
            return -2;
        neg = d < 0;
        mag = (uint64_t)fabs(d);
    }
    if (neg) {
        if (mag == 0) {
            *bits = 0;
            return 0;
        }
        if (int_min[t] == 0 || mag - 1 > (uint64_t)(-(int_min[t] + 1)))
            return -2;
        *bits = (uint64_t)0 - mag;
    } else {
        if (mag > int_max[t])
            return -2;
        *bits = mag;
    }
    return 0;
}

/* Parses one ascii token into a little-endian field of type t at dst.
 * Returns 0, -1 (not a number) or -2 (out of range). */
static int parse_value(const char *p, size_t len, wpd_type t, locale_t loc, uint8_t *dst)
{
    if (t == WPD_F32 || t == WPD_F64) {
        double d;
        if (parse_double(p, len, loc, &d))
            return -1;
        if (t == WPD_F64) {
            memcpy(dst, &d, 8);
        } else {
            float f = (float)d;
            memcpy(dst, &f, 4);
        }
        return 0;
    }
    uint64_t bits;
    int rc = parse_int_value(p, len, t, loc, &bits);
    if (rc)
        return rc;
    memcpy(dst, &bits, wpd_type_size(t)); /* low bytes first: little-endian host */
    return 0;
}

/* ------------------------------------------------------------------ header */

typedef struct header_parser {
    wpd_reader *r;
    ply_reader *pr;
    char *buf;
    size_t len, cap, pos;    /* bytes read, allocated, start of the next line */
    int eof;
    unsigned line_no;
    int have_format, done;
} header_parser;

/* Returns the next header line (without its newline, NUL-terminated in
 * place) in *line. Returns 1, 0 when the file ends, -1 with err set. */
static int header_next_line(header_parser *hp, char **line, size_t *len, wpd_error *err)
{
    const char *path = hp->r->hdr.path;
    for (;;) {
        char *nl = hp->buf ? memchr(hp->buf + hp->pos, '\n', hp->len - hp->pos) : NULL;
        if (nl || (hp->eof && hp->pos < hp->len)) {
            char *start = hp->buf + hp->pos;
            size_t n = nl ? (size_t)(nl - start) : hp->len - hp->pos;
            if (n > PLY_LINE_MAX)
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY header line %u is longer than %u bytes",
                                path, hp->line_no + 1, PLY_LINE_MAX);
            hp->pos += n + (nl != NULL);
            start[n] = '\0'; /* the '\n' or the spare byte past len */
            *line = start;
            *len = n;
            hp->line_no++;
            return 1;
        }
        if (hp->eof)
            return 0;
        if (hp->len - hp->pos > PLY_LINE_MAX)
            return wpd_fail(err, WPD_E_INPUT, "%s: PLY header line %u is longer than %u bytes",
                            path, hp->line_no + 1, PLY_LINE_MAX);
        if (hp->len >= PLY_HEADER_MAX)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: PLY header has no end_header line within the first %u bytes",
                            path, PLY_HEADER_MAX);
        size_t want = PLY_HEADER_READ;
        if (hp->len + want > PLY_HEADER_MAX)
            want = PLY_HEADER_MAX - hp->len;
        if (hp->len + want + 1 > hp->cap) {
            size_t cap = hp->cap ? hp->cap * 2 : PLY_HEADER_READ + 1;
            while (cap < hp->len + want + 1)
                cap *= 2;
            char *grown = realloc(hp->buf, cap);
            if (!grown)
                return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
            hp->buf = grown;
            hp->cap = cap;
        }
        ssize_t n = pread_full(hp->r->fd, hp->buf + hp->len, want, hp->len);
        if (n < 0)
            return wpd_fail_errno(err, "%s: cannot read", path);
        if ((size_t)n < want)
            hp->eof = 1;
        hp->len += (size_t)n;
    }
}

/* Strips trailing whitespace (CR of CRLF lines, trailing blanks). */
static void rstrip(char *line, size_t *len)
{
    while (*len && is_space((unsigned char)line[*len - 1]))
        line[--*len] = '\0';
}

/* Splits line in place into at most max tokens; returns the count, or
 * max + 1 when there are more. */
static int split_tokens(char *line, char **tok, int max)
{
    int n = 0;
    char *p = line;
    for (;;) {
        while (*p && is_space((unsigned char)*p))
            p++;
        if (!*p)
            return n;
        if (n == max)
            return max + 1;
        tok[n++] = p;
        while (*p && !is_space((unsigned char)*p))
            p++;
        if (*p)
            *p++ = '\0';
    }
}

static int header_fail(header_parser *hp, wpd_error *err, const char *what, const char *arg)
{
    return wpd_fail(err, WPD_E_INPUT, "%s: PLY header line %u: %s%s%s%s", hp->r->hdr.path,
                    hp->line_no, what, arg ? " '" : "", arg ? arg : "", arg ? "'" : "");
}

/* Appends a copy of text to a string array of the header (comments or
 * obj_info), keeping the count equal to the allocated entries. */
static int push_string(char ***arr, uint32_t *n, const char *text)
{
    char **grown = realloc(*arr, (*n + 1) * sizeof **arr);
    if (!grown)
        return -1;
    *arr = grown;
    if (!(grown[*n] = strdup(text)))
        return -1;
    ++*n;
    return 0;
}

/* The text of a comment / obj_info line after its keyword and one blank. */
static const char *line_text(const char *line, size_t keyword_len)
{
    const char *p = line + keyword_len;
    return *p ? p + 1 : p;
}

static int parse_format(header_parser *hp, char **tok, int n, wpd_error *err)
{
    if (hp->have_format)
        return header_fail(hp, err, "second format line", NULL);
    if (n != 3)
        return header_fail(hp, err, "expected 'format <encoding> 1.0'", NULL);
    int enc = -1;
    for (int i = 0; i < 3; i++)
        if (!strcmp(tok[1], encoding_names[i]))
            enc = i;
    if (enc < 0)
        return header_fail(hp, err, "unknown format", tok[1]);
    double version;
    if (!parse_double_fast(tok[2], strlen(tok[2]), &version) || version != 1.0)
        return header_fail(hp, err, "unsupported PLY version", tok[2]);
    hp->pr->enc = (wpd_ply_encoding)enc;
    hp->have_format = 1;
    return 0;
}

static int parse_element(header_parser *hp, char **tok, int n, wpd_error *err)
{
    ply_reader *pr = hp->pr;
    if (n != 3)
        return header_fail(hp, err, "expected 'element <name> <count>'", NULL);
    int neg;
    uint64_t count;
    if (parse_integer(tok[2], strlen(tok[2]), &neg, &count) != 1 || neg || tok[2][0] == '+')
        return header_fail(hp, err, "bad element count", tok[2]);
    ply_elem *grown = realloc(pr->elems, (pr->nelems + 1) * sizeof *grown);
    if (!grown)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", hp->r->hdr.path);
    pr->elems = grown;
    ply_elem *e = &pr->elems[pr->nelems++];
    memset(e, 0, sizeof *e);
    snprintf(e->name, sizeof e->name, "%s", tok[1]);
    e->count = count;
    e->first_prop = pr->nprops;
    return 0;
}

static int parse_property(header_parser *hp, char **tok, int n, wpd_error *err)
{
    ply_reader *pr = hp->pr;
    if (!pr->nelems)
        return header_fail(hp, err, "property before any element", NULL);
    ply_prop p;
    memset(&p, 0, sizeof p);
    const char *name;
    if (n >= 2 && !strcmp(tok[1], "list")) {
        if (n != 5)
            return header_fail(hp, err,
                               "expected 'property list <count type> <item type> <name>'", NULL);
        if (wpd_type_parse(tok[2], &p.count_type))
            return header_fail(hp, err, "unknown list count type", tok[2]);
        if (!is_int_type(p.count_type))
            return header_fail(hp, err, "list count type is not an integer type", tok[2]);
        if (wpd_type_parse(tok[3], &p.type))
            return header_fail(hp, err, "unknown list item type", tok[3]);
        p.is_list = 1;
        name = tok[4];
    } else {
        if (n != 3)
            return header_fail(hp, err, "expected 'property <type> <name>'", NULL);
        if (wpd_type_parse(tok[1], &p.type))
            return header_fail(hp, err, "unknown property type", tok[1]);
        name = tok[2];
    }
    snprintf(p.name, sizeof p.name, "%s", name);
    if (pr->nprops == pr->props_cap) {
        uint32_t cap = pr->props_cap ? pr->props_cap * 2 : 32;
        ply_prop *grown = realloc(pr->props, cap * sizeof *grown);
        if (!grown)
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", hp->r->hdr.path);
        pr->props = grown;
        pr->props_cap = cap;
    }
    pr->props[pr->nprops++] = p;
    ply_elem *e = &pr->elems[pr->nelems - 1];
    e->nprops++;
    e->has_lists |= p.is_list;
    e->item_bytes += wpd_type_size(p.is_list ? p.count_type : p.type);
    /* A vertex property whose name does not fit a schema dimension. */
    if (!strcmp(e->name, "vertex") && strlen(name) >= WPD_DIM_NAME_MAX && !p.is_list)
        return header_fail(hp, err, "vertex property name too long", name);
    return 0;
}

/* Handles one header line. */
static int header_line(header_parser *hp, char *line, size_t len, wpd_error *err)
{
    wpd_ply_info *info = &hp->r->hdr.ply;
    if (memchr(line, '\0', len))
        return header_fail(hp, err, "binary data before end_header", NULL);
    rstrip(line, &len);
    if (hp->line_no == 1) {
        if (strcmp(line, "ply"))
            return wpd_fail(err, WPD_E_INPUT, "%s: not a PLY file (no 'ply' magic line)",
                            hp->r->hdr.path);
        return 0;
    }
    size_t kw = strcspn(line, " \t");
    if ((kw == 7 && !strncmp(line, "comment", 7)) || (kw == 8 && !strncmp(line, "obj_info", 8))) {
        int is_comment = kw == 7;
        if (push_string(is_comment ? &info->comments : &info->obj_info,
                        is_comment ? &info->ncomments : &info->nobj_info, line_text(line, kw)))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", hp->r->hdr.path);
        return 0;
    }
    char *tok[PLY_LINE_TOKENS];
    int n = split_tokens(line, tok, PLY_LINE_TOKENS);
    if (n == 0)
        return 0; /* blank line */
    if (n > PLY_LINE_TOKENS - 1)
        return header_fail(hp, err, "too many words on the line", NULL);
    if (!strcmp(tok[0], "format"))
        return parse_format(hp, tok, n, err);
    if (!strcmp(tok[0], "element"))
        return parse_element(hp, tok, n, err);
    if (!strcmp(tok[0], "property"))
        return parse_property(hp, tok, n, err);
    if (!strcmp(tok[0], "end_header")) {
        if (n != 1)
            return header_fail(hp, err, "text after end_header", NULL);
        hp->done = 1;
        return 0;
    }
    return header_fail(hp, err, "unknown keyword", tok[0]);
}

/* Reads and parses the header up to end_header; sets pr->body_offset. */
static int parse_header(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    header_parser hp = {.r = r, .pr = pr};
    int rc = 0;
    while (!hp.done) {
        char *line = NULL;
        size_t len = 0;
        rc = header_next_line(&hp, &line, &len, err);
        if (rc < 0)
            break;
        if (rc == 0) {
            rc = hp.line_no == 0 || hp.len == 0
                     ? wpd_fail(err, WPD_E_INPUT, "%s: not a PLY file (no 'ply' magic line)",
                                r->hdr.path)
                     : wpd_fail(err, WPD_E_INPUT, "%s: PLY header has no end_header line",
                                r->hdr.path);
            break;
        }
        if ((rc = header_line(&hp, line, len, err)) < 0)
            break;
    }
    free(hp.buf);
    if (rc < 0)
        return -1;
    if (!hp.have_format)
        return wpd_fail(err, WPD_E_INPUT, "%s: PLY header has no format line", r->hdr.path);
    pr->body_offset = hp.pos;
    return 0;
}

/* ------------------------------------------------------------------ layout */

/* Builds the record schema from the vertex element's scalar properties. */
static int build_schema(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    const char *path = r->hdr.path;
    const ply_elem *v = &pr->elems[pr->vertex];
    wpd_schema *s = &r->hdr.schema;
    memset(s, 0, sizeof *s);
    uint32_t offset = 0;
    for (uint32_t i = 0; i < v->nprops; i++) {
        ply_prop *p = &pr->props[v->first_prop + i];
        if (p->is_list) {
            if (!strcmp(p->name, "x") || !strcmp(p->name, "y") || !strcmp(p->name, "z"))
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex property '%s' is a list",
                                path, p->name);
            continue;
        }
        if (wpd_schema_find(s, p->name) >= 0)
            return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex property '%s' appears twice",
                            path, p->name);
        if (wpd_schema_add(s, p->name, p->type, offset) < 0)
            return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex element has more than %d properties",
                            path, WPD_MAX_DIMS);
        p->offset = offset;
        offset += (uint32_t)wpd_type_size(p->type);
    }
    s->record_size = offset;
    s->dim_x = wpd_schema_find(s, "x");
    s->dim_y = wpd_schema_find(s, "y");
    s->dim_z = wpd_schema_find(s, "z");
    if (s->dim_x < 0 || s->dim_y < 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex element has no '%s' property", path,
                        s->dim_x < 0 ? "x" : "y");
    pr->record_size = offset;
    const int idx[3] = {s->dim_x, s->dim_y, s->dim_z};
    for (int c = 0; c < 3; c++) {
        pr->coord[c].present = idx[c] >= 0;
        if (idx[c] >= 0) {
            pr->coord[c].type = s->dims[idx[c]].type;
            pr->coord[c].offset = s->dims[idx[c]].offset;
        }
    }
    for (uint32_t i = 0; i < s->ndims; i++) {
        size_t size = wpd_type_size(s->dims[i].type);
        if (size > 1) {
            pr->swap_offset[pr->nswap] = (uint16_t)s->dims[i].offset;
            pr->swap_size[pr->nswap++] = (uint8_t)size;
        }
    }
    return 0;
}

/* Copies the element list into hdr.ply (owned by the header). */
static int fill_ply_info(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    wpd_ply_info *info = &r->hdr.ply;
    info->encoding = pr->enc;
    info->vertex_element = pr->vertex;
    info->elements = calloc(pr->nelems, sizeof *info->elements);
    if (!info->elements)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    info->nelements = pr->nelems;
    for (uint32_t i = 0; i < pr->nelems; i++) {
        wpd_ply_element_info *e = &info->elements[i];
        snprintf(e->name, sizeof e->name, "%s", pr->elems[i].name);
        e->count = pr->elems[i].count;
        e->nprops = pr->elems[i].nprops;
        e->has_lists = pr->elems[i].has_lists;
    }
    return 0;
}

/* Binary vertex data that does not fit: reported as where the file ends. */
static int fail_vertex_space(const wpd_reader *r, const ply_elem *v, uint64_t need,
                             uint64_t avail, uint64_t offset, wpd_error *err)
{
    return wpd_fail(err, WPD_E_INPUT,
                    "%s: file ends after %llu of %llu vertices (PLY element 'vertex' count "
                    "%llu needs %s%llu bytes but only %llu bytes follow offset %llu)",
                    r->hdr.path, (unsigned long long)(avail / v->item_bytes),
                    (unsigned long long)v->count, (unsigned long long)v->count,
                    v->has_lists ? "at least " : "", (unsigned long long)need,
                    (unsigned long long)avail, (unsigned long long)offset);
}

/* Checks, before anything is looped over, that the elements up to and
 * including the vertex element can fit in the bytes after the header:
 * binary items need at least their scalar and list-count bytes, ascii items
 * at least one character and one separator per property (the last
 * separator may be missing). */
static int check_sizes(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    uint64_t avail = r->hdr.file_size > pr->body_offset ? r->hdr.file_size - pr->body_offset : 0;
    uint64_t slack = pr->enc == WPD_PLY_ASCII ? 1 : 0;
    uint64_t need = 0;
    for (uint32_t i = 0; i <= pr->vertex; i++) {
        const ply_elem *e = &pr->elems[i];
        uint64_t per_item = pr->enc == WPD_PLY_ASCII ? 2 * (uint64_t)e->nprops : e->item_bytes;
        uint64_t total;
        int overflow = muladd_u64(e->count, per_item, need, &total);
        if (!overflow && total <= avail + slack) {
            need = total;
            continue;
        }
        if (!overflow && i == pr->vertex && !slack)
            return fail_vertex_space(r, e, total - need, avail - need,
                                     pr->body_offset + need, err);
        char needed[32] = "more than 2^64";
        if (!overflow)
            snprintf(needed, sizeof needed, "%llu", (unsigned long long)(total - slack));
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: PLY element '%s' count %llu cannot fit in the file: the data up "
                        "to it needs at least %s bytes but only %llu bytes follow the header",
                        r->hdr.path, e->name, (unsigned long long)e->count, needed,
                        (unsigned long long)avail);
    }
    return 0;
}

/* Binary: skips one element's items starting at the stream position. */
static int skip_binary_element(wpd_reader *r, ply_reader *pr, const ply_elem *e,
                               wpd_error *err)
{
    ply_stream *s = &pr->st;
    int be = pr->enc == WPD_PLY_BINARY_BE;
    if (!e->has_lists) {
        uint64_t bytes = e->count * e->item_bytes; /* bounded by check_sizes */
        if (!stream_skip(s, bytes))
            goto short_file;
        return 0;
    }
    for (uint64_t item = 0; item < e->count; item++) {
        for (uint32_t k = 0; k < e->nprops; k++) {
            const ply_prop *p = &pr->props[e->first_prop + k];
            if (!p->is_list) {
                if (!stream_skip(s, wpd_type_size(p->type)))
                    goto short_item;
                continue;
            }
            size_t cs = wpd_type_size(p->count_type);
            int rc = stream_need(s, cs, r->hdr.path, err);
            if (rc < 0)
                return -1;
            if (rc == 0)
                goto short_item;
            int64_t n = read_int_field((const uint8_t *)s->buf + s->pos, p->count_type, be);
            s->pos += cs;
            uint64_t bytes;
            if (n < 0)
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY element '%s' item %llu: negative list count",
                                r->hdr.path, e->name, (unsigned long long)item);
            if (__builtin_mul_overflow((uint64_t)n, wpd_type_size(p->type), &bytes) ||
                !stream_skip(s, bytes))
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

/* Ascii: skips count items of an element (tokens; lists by their count). */
static int skip_ascii_element(wpd_reader *r, ply_reader *pr, const ply_elem *e, wpd_error *err)
{
    if (!e->nprops)
        return 0;
    for (uint64_t item = 0; item < e->count; item++) {
        for (uint32_t k = 0; k < e->nprops; k++) {
            const ply_prop *p = &pr->props[e->first_prop + k];
            const char *tok;
            size_t len;
            int rc = stream_token(&pr->st, &tok, &len, r->hdr.path, err);
            if (rc < 0)
                return -1;
            if (rc == 0)
                goto short_file;
            if (!p->is_list)
                continue;
            uint64_t n;
            int neg;
            if (parse_integer(tok, len, &neg, &n) != 1 || (neg && n))
                return wpd_fail(err, WPD_E_INPUT,
                                "%s: PLY element '%s' item %llu: bad list count '%.*s'",
                                r->hdr.path, e->name, (unsigned long long)item,
                                (int)(len > 40 ? 40 : len), tok);
            for (uint64_t j = 0; j < n; j++) {
                rc = stream_token(&pr->st, &tok, &len, r->hdr.path, err);
                if (rc < 0)
                    return -1;
                if (rc == 0)
                    goto short_file;
            }
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
    stream_seek(&pr->st, pr->body_offset);
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
        stream_seek(&pr->st, off);
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
    if (muladd_u64(v->count, v->item_bytes, 0, &need))
        need = UINT64_MAX;
    return need > avail ? fail_vertex_space(r, v, need, avail, off, err) : 0;
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
    ssize_t got = pread_full(r->fd, rec, bytes, pr->vertex_offset + pr->next * pr->record_size);
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
            int rc = stream_need(s, size, r->hdr.path, err);
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
            int64_t cnt = read_int_field(src, p->count_type, be);
            uint64_t bytes;
            if (cnt < 0)
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex %llu: negative list count",
                                r->hdr.path, (unsigned long long)(pr->next + i));
            if (__builtin_mul_overflow((uint64_t)cnt, wpd_type_size(p->type), &bytes) ||
                !stream_skip(s, bytes))
                return fail_truncated(r, pr->next + i, err);
        }
    }
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
            int rc = stream_token(&pr->st, &tok, &len, r->hdr.path, err);
            if (rc < 0)
                return -1;
            if (rc == 0)
                return fail_truncated(r, pr->next + i, err);
            if (p->is_list) {
                uint64_t cnt;
                int neg;
                if (parse_integer(tok, len, &neg, &cnt) != 1 || (neg && cnt))
                    goto bad_value;
                for (uint64_t j = 0; j < cnt; j++) {
                    rc = stream_token(&pr->st, &tok, &len, r->hdr.path, err);
                    if (rc < 0)
                        return -1;
                    if (rc == 0)
                        return fail_truncated(r, pr->next + i, err);
                }
                continue;
            }
            rc = parse_value(tok, len, p->type, pr->c_locale, out + p->offset);
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
    return 0;
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
    while (b->n < b->cap && pr->next < pr->count) {
        size_t n = b->cap - b->n;
        if (n > chunk)
            n = chunk;
        if (n > pr->count - pr->next)
            n = (size_t)(pr->count - pr->next);
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

static const wpd_reader_ops seekable_ops = {ply_read, ply_seek, ply_close};
static const wpd_reader_ops stream_ops = {ply_read, NULL, ply_close};

static int open_reader(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    const char *path = r->hdr.path;
    if (parse_header(r, pr, err))
        return -1;
    uint32_t v = 0;
    while (v < pr->nelems && strcmp(pr->elems[v].name, "vertex"))
        v++;
    if (v == pr->nelems)
        return wpd_fail(err, WPD_E_INPUT, "%s: PLY header has no 'vertex' element", path);
    pr->vertex = v;
    pr->count = pr->elems[v].count;
    if (build_schema(r, pr, err) || fill_ply_info(r, pr, err) || check_sizes(r, pr, err))
        return -1;
    r->hdr.format = WPD_FMT_PLY;
    r->hdr.point_count = pr->count;
    if (stream_init(&pr->st, r->fd, r->hdr.file_size, pr->body_offset, err, path))
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
