/* ply_stream.h - a buffered view of a PLY file from some offset, for the
 * ascii body and for walking binary items of varying size. Private to the
 * PLY reader (src/io/ply/).
 *
 * The buffer has one byte beyond cap for a NUL sentinel, so ascii scanning
 * needs no bounds checks. Reads use pread: the view owns its file offset,
 * so seeking is free and the descriptor's position is never touched.
 */
#ifndef WPD_PLY_STREAM_H
#define WPD_PLY_STREAM_H

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "common/error.h"
#include "io/decimal.h"

/* Longest ascii token: whatever the tokenizer passes, the number parser
 * takes (decimal.h). */
#define PLY_TOKEN_MAX WPD_DECIMAL_TOKEN_MAX

typedef struct ply_stream {
    int fd;
    uint64_t file_size;
    char *buf;
    size_t cap, pos, end;    /* unread bytes are buf[pos..end) */
    uint64_t file_pos;       /* file offset of buf[end] */
    int eof;
    uint64_t line;           /* ascii: line of the next unread byte (the
                                caller sets it after a seek) */
    uint64_t token_line;     /* ascii: line of the token last returned */
} ply_stream;

/* Allocates the buffer for reading fd (file_size bytes long) from
 * body_offset on; it is sized to the body when that is small. Does not
 * position the view: call ply_stream_seek. Returns 0, or -1 with err set
 * (WPD_E_MEMORY naming path). s->buf is freed by the caller (free). */
int ply_stream_init(ply_stream *s, int fd, uint64_t file_size, uint64_t body_offset,
                    wpd_error *err, const char *path);

/* Drops the buffered bytes; the next read starts at file offset off. */
void ply_stream_seek(ply_stream *s, uint64_t off);

/* Makes at least k (<= cap) unread bytes available at buf + pos. Returns 1,
 * 0 when the file ends first, or -1 with err set (read error on path). */
int ply_stream_need(ply_stream *s, size_t k, const char *path, wpd_error *err);

/* Skips n bytes. Returns 1, or 0 if that passes the end of the file. */
int ply_stream_skip(ply_stream *s, uint64_t n);

/* Finds the next whitespace-separated token. Returns 1 with *tok and *len
 * set (the token is followed by a separator or the NUL sentinel, and stays
 * valid until the next call) and s->token_line the line it is on (s->line
 * counts the newlines passed), 0 at end of file, -1 with err set (read
 * error, NUL byte in the data, token longer than PLY_TOKEN_MAX). */
int ply_stream_token(ply_stream *s, const char **tok, size_t *len, const char *path,
                     wpd_error *err);

/* Which bytes separate ascii tokens (header words too): space, \t, \n,
 * \v, \f, \r. NUL is not one: it ends a scan as the buffer sentinel. The
 * entry is PLY_NEWLINE for \n, 1 for the others. */
#define PLY_NEWLINE 2
extern const uint8_t ply_space_table[256];

static inline int ply_is_space(unsigned char c) { return ply_space_table[c]; }

#endif
