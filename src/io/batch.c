#include "io/batch.h"

#include <stdlib.h>
#include <string.h>

size_t wpd_batch_bytes(uint32_t record_size)
{
    return (size_t)WPD_BATCH_POINTS * (record_size + 24);
}

int wpd_batch_init(wpd_batch *b, size_t cap, uint32_t record_size)
{
    memset(b, 0, sizeof *b);
    /* Records of up to 64 KB (a LAS header may say so for a file of no
     * points) must not make a 65536-point batch a 4 GB allocation. */
    size_t most = WPD_BATCH_MAX_BYTES / (record_size ? record_size : 1);
    if (cap > most)
        cap = most ? most : 1;
    b->records = malloc(cap * (record_size ? record_size : 1));
    b->xyz = malloc(cap * 3 * sizeof *b->xyz);
    if (!b->records || !b->xyz) {
        wpd_batch_free(b);
        return -1;
    }
    b->cap = cap;
    b->record_size = record_size;
    return 0;
}

void wpd_batch_free(wpd_batch *b)
{
    free(b->records);
    free(b->xyz);
    memset(b, 0, sizeof *b);
}
