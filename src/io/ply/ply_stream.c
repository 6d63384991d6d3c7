/* ply_stream.c - a buffered view of a PLY file (see ply_stream.h). */
#include "io/ply/ply_stream.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PLY_STREAM_BUF (1u << 20)   /* private buffer for ascii and skipping */
#define PLY_STREAM_MIN (4u << 10)   /* smallest one: > PLY_TOKEN_MAX + any item */

/* The buffer holds the whole body when that is smaller than PLY_STREAM_BUF
 * (one byte more, so that the read which meets the end of the file fits
 * and sets eof): a small file does not cost a 1 MiB allocation. It is never
 * smaller than PLY_STREAM_MIN, so a full buffer always holds a whole token
 * or item even if the file grew after it was opened. */
int ply_stream_init(ply_stream *s, int fd, uint64_t file_size, uint64_t body_offset,
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

void ply_stream_seek(ply_stream *s, uint64_t off)
{
    s->pos = s->end = 0;
    s->buf[0] = '\0';
    s->file_pos = off;
    s->eof = off >= s->file_size;
}

/* Moves the unread bytes to the front of the buffer and reads more after
 * them. Returns the bytes added (0 at end of file or when the buffer is
 * full), or -1 with err set. One pread, not wpd_pread_full: whatever
 * arrived is enough to go on with, and the callers loop as they need. */
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
int ply_stream_need(ply_stream *s, size_t k, const char *path, wpd_error *err)
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
int ply_stream_skip(ply_stream *s, uint64_t n)
{
    size_t avail = s->end - s->pos;
    if (n <= avail) {
        s->pos += (size_t)n;
        return 1;
    }
    uint64_t off = s->file_pos + (n - avail);
    if (off < s->file_pos || off > s->file_size)
        return 0;
    ply_stream_seek(s, off);
    return 1;
}

/* A table load beats six comparisons in the hottest loop of the ascii
 * reader. */
const uint8_t ply_space_table[256] = {
    [' '] = 1, ['\n'] = PLY_NEWLINE, ['\r'] = 1, ['\t'] = 1, ['\v'] = 1, ['\f'] = 1,
};

/* Finds the next whitespace-separated token. Returns 1 with *tok and *len set
 * (the token is followed by a separator or the NUL sentinel) and the lines
 * counted, 0 at end of file, -1 with err set. */
int ply_stream_token(ply_stream *s, const char **tok, size_t *len, const char *path,
                     wpd_error *err)
{
    for (;;) {
        char *p = s->buf + s->pos;
        uint8_t space;
        uint64_t newlines = 0; /* a local: a store through s could alias buf */
        while ((space = ply_space_table[(unsigned char)*p])) {
            newlines += space == PLY_NEWLINE;
            p++;
        }
        s->line += newlines; /* the blanks are passed once: pos moves past them */
        s->token_line = s->line;
        char *q = p;
        while (*q && !ply_is_space((unsigned char)*q))
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
