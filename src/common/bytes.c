/* bytes.c - packing arrays into bytes and taking them out. */
#include "common/bytes.h"

#include <stdlib.h>
#include <string.h>

void wpd_bytes_put(wpd_bytes *b, const void *src, size_t n)
{
    if (b->failed || n == 0)
        return;
    if (b->len + n > b->cap) {
        size_t cap = 2 * (b->cap + n);
        uint8_t *p = realloc(b->p, cap);
        if (!p) {
            b->failed = 1;
            b->error = 4; /* WPD_E_MEMORY (common/error.h) */
            return;
        }
        b->p = p, b->cap = cap;
    }
    memcpy(b->p + b->len, src, n);
    b->len += n;
}

void wpd_bytes_put_u64(wpd_bytes *b, uint64_t v)
{
    wpd_bytes_put(b, &v, sizeof v);
}

void wpd_bytes_free(wpd_bytes *b)
{
    free(b->p);
    memset(b, 0, sizeof *b);
}

int wpd_bytes_get(wpd_bytes_in *in, void *dst, size_t n)
{
    if (in->bad || n > in->len - in->at) {
        in->bad = 1;
        return -1;
    }
    if (n)
        memcpy(dst, in->p + in->at, n);
    in->at += n;
    return 0;
}

uint64_t wpd_bytes_get_u64(wpd_bytes_in *in)
{
    uint64_t v = 0;
    return wpd_bytes_get(in, &v, sizeof v) ? 0 : v;
}

size_t wpd_bytes_left(const wpd_bytes_in *in)
{
    return in->bad ? 0 : in->len - in->at;
}
