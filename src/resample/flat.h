/* flat.h - all samples of a run as flat arrays in global-index order: the
 * order an in-memory run has always held them in, so that ties (equal
 * distances, common on quantised coordinates) break alike whatever the
 * tiling (internal to src/resample/). */
#ifndef WPD_FLAT_H
#define WPD_FLAT_H

#include "resample/run.h"

typedef struct wpd_flat {
    size_t n;
    uint64_t *gid;            /* ascending */
    double *xyz;              /* frame coordinates */
    uint8_t *edge;            /* or NULL */
    int *tile;                /* tile of each sample */
} wpd_flat;

/* The store as one flat set. Returns 0 or -1 (out of memory; f stays valid
 * for wpd_flat_free). */
int wpd_flat_from_store(const wpd_run *run, wpd_flat *f);
void wpd_flat_free(wpd_flat *f);

#endif
