/* batch.h - a block of points moving through the pipeline: raw records in
 * the schema's layout plus decoded double coordinates. */
#ifndef WPD_BATCH_H
#define WPD_BATCH_H

#include <stddef.h>
#include <stdint.h>

typedef struct wpd_batch {
    size_t cap;            /* capacity in points */
    size_t n;              /* points held */
    uint32_t record_size;  /* bytes per record */
    uint8_t *records;      /* n * record_size bytes */
    double *xyz;           /* 3 * n doubles: x0 y0 z0 x1 ... */
} wpd_batch;

/* Record bytes a batch holds at most. */
#define WPD_BATCH_MAX_BYTES ((size_t)64 << 20)

/* Points a streaming pass reads at once (io/pass.h). */
enum { WPD_BATCH_POINTS = 65536 };

/* Bytes of one batch of WPD_BATCH_POINTS points with their records. */
size_t wpd_batch_bytes(uint32_t record_size);

/* Allocates room for cap points of record_size bytes - fewer when that
 * would pass WPD_BATCH_MAX_BYTES of records (b->cap says how many, at least
 * 1). Returns 0, or -1 if out of memory (the batch is then zeroed and safe
 * to free). */
int wpd_batch_init(wpd_batch *b, size_t cap, uint32_t record_size);
/* Releases the buffers and zeroes the batch. */
void wpd_batch_free(wpd_batch *b);

#endif
