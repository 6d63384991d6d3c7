/* poisson.h - one Poisson-disk pass over a block: greedy pruning in a fixed
 * pseudo-random order.
 *
 * Every candidate gets the priority wpd_priority(seed, global index);
 * candidates are visited in increasing priority and a visited candidate
 * that has not been removed is kept and removes every other candidate
 * closer than r. The kept set is therefore the one defined by "a candidate
 * is kept iff no kept candidate of smaller priority lies within r": it
 * depends on the seed and on the points, not on how a cloud was cut into
 * blocks (given the samples of neighbouring blocks) or on threads.
 *
 * Radii: a normal point has radius r, a sharp-feature point r/2; two points
 * conflict when closer than the mean of their radii. Accepted samples of
 * neighbouring blocks (fixed) have radius r and are never removed.
 */
#ifndef WPD_POISSON_H
#define WPD_POISSON_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_poisson_input {
    const double *xyz;       /* block points, x y z each, block frame */
    const uint64_t *gid;     /* global index of each point: fixes the order */
    const uint8_t *edge;     /* 1 = sharp-feature point (radius r/2); NULL: none */
    const uint32_t *cand;    /* candidate points (indices into xyz), or NULL: all */
    size_t ncand;            /* number of candidates (all points when cand NULL) */
    const double *fixed_xyz; /* accepted samples of neighbouring blocks */
    size_t nfixed;
    double r;                /* > 0 */
    uint64_t seed;
    int threads;             /* <= 0: OpenMP default */
} wpd_poisson_input;

/* Runs one pass; writes the kept candidates' point indices to out (room for
 * ncand), ascending. Returns how many were kept, or -1 with err set. */
long wpd_poisson_pass(const wpd_poisson_input *in, uint32_t *out, wpd_error *err);

/* For several passes over the same candidates at different radii (the
 * refinement loop): the grid, priorities and visiting order are built once
 * by wpd_poisson_prepare (for radius in->r; the arrays in *in are borrowed
 * and must outlive the context), and each wpd_poisson_run costs only the
 * greedy pruning. A run at a radius far from the prepared one rebuilds the
 * grid first. A context must not be run by two threads at once. */
typedef struct wpd_poisson wpd_poisson;

/* Returns a context, or NULL with err set. */
wpd_poisson *wpd_poisson_prepare(const wpd_poisson_input *in, wpd_error *err);
/* One pass at radius r (> 0), as wpd_poisson_pass. */
long wpd_poisson_run(wpd_poisson *ps, double r, uint32_t *out, wpd_error *err);
/* Occupied cells of the context's grid and (if cell is not NULL) its cell
 * edge: a voxel count at that scale, aligned to the candidates' minimum. */
size_t wpd_poisson_occupied_cells(const wpd_poisson *ps, double *cell);
/* Frees a context; NULL is fine. */
void wpd_poisson_release(wpd_poisson *ps);

#endif
