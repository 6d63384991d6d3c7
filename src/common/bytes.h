/* bytes.h - a growable byte buffer to pack arrays into, and a reader that
 * takes them out again with every length checked: what the ranks of an
 * MPI run send each other (resample/ranks.c). */
#ifndef WPD_BYTES_H
#define WPD_BYTES_H

#include <stddef.h>
#include <stdint.h>

typedef struct wpd_bytes {
    uint8_t *p;
    size_t len, cap;
    int failed;               /* 1: a put ran out of memory, or a packer could not
                                 read what it packs (the rest ignored) */
    int error;                /* then the WPD_E_* code: WPD_E_MEMORY for a put */
} wpd_bytes;

/* Appends n bytes of src (nothing once failed). */
void wpd_bytes_put(wpd_bytes *b, const void *src, size_t n);
void wpd_bytes_put_u64(wpd_bytes *b, uint64_t v);
void wpd_bytes_free(wpd_bytes *b);

typedef struct wpd_bytes_in {
    const uint8_t *p;
    size_t len, at;
    int bad;                  /* 1: a get asked for more than was left */
} wpd_bytes_in;

/* Takes n bytes into dst; 0, or -1 (and bad set) when fewer are left. */
int wpd_bytes_get(wpd_bytes_in *in, void *dst, size_t n);
/* A u64; 0 when bad. */
uint64_t wpd_bytes_get_u64(wpd_bytes_in *in);
/* Bytes left. */
size_t wpd_bytes_left(const wpd_bytes_in *in);

#endif
