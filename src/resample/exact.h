/* exact.h - the exact count through tiles (internal to src/resample/):
 * coverage-aware elimination (wpd/eliminate.h) with the samples staying in
 * their tiles. A sweep is
 *   1. costs, per tile (any order): each tile's samples' costs and
 *      crowding distances from its input points and halo and the samples
 *      within 2 R of its box (R: the reach of eliminate.h, the input halo):
 *      exactly the values the whole cloud gives;
 *   2. two global selections (core/select.h): the candidate bound (the
 *      cost of rank q + min(q, live / 20), q the deletions still to make)
 *      and the median crowding distance;
 *   3. decisions (exact_decide.c): the sweep's greedy - a candidate is
 *      taken unless a candidate taken before it in (rank, global index)
 *      order lies within twice the larger of their costs - decided tile by
 *      tile with three values, as the Poisson pass decides its points
 *      (poisson_pass.c): a tile decides for certain only what the greedy
 *      over all candidates decides, and leaves UNKNOWN what depends on
 *      candidates it cannot see; rounds repeat until all are decided;
 *   4. the first q taken candidates in (rank, index) order: a third
 *      selection; each tile deletes its own.
 * Only the selections' histograms and a few numbers per tile are global,
 * and the result is the one-block sweep's (eliminate.c), byte for byte,
 * whatever the tiling and the threads.
 */
#ifndef WPD_EXACT_H
#define WPD_EXACT_H

#include "resample/run.h"

enum { EXACT_UNDECIDED = 0, EXACT_TAKEN = 1, EXACT_SPARED = 2 };

/* One tile's part of a sweep. */
typedef struct exact_tile {
    size_t n;         /* its samples */
    uint64_t *cost;   /* [n] squared cost bits (eliminate.h) of its samples */
    double *nn;       /* [n] their crowding distances */
    uint8_t *half;    /* [n] 1: a sample of radius r/2 (sharp label), or NULL */
    size_t ncand;
    uint32_t *cand;   /* [ncand] sample indices of its candidates, ascending */
    uint64_t *cgid;   /* [ncand] their global indices */
    double *cxyz;     /* [3 ncand] their coordinates */
    uint64_t *rank;   /* [ncand] their rank bits */
    uint8_t *state;   /* [ncand] decisions so far (fixed during a round) */
    uint8_t *next;    /* [ncand] this round's decisions */
    size_t undecided; /* candidates still EXACT_UNDECIDED */
} exact_tile;

typedef struct exact_sweep {
    wpd_run *run;
    exact_tile *tile;   /* [ntiles] */
    double reach;       /* R */
    double conflict;    /* the largest conflict distance of two candidates */
    int labelled;       /* samples carry sharp labels */
    uint64_t tau;       /* the candidate bound (bits of a cost_of) */
    double median;      /* the median crowding distance */
} exact_sweep;

/* Step 3 for tile t (a wpd_tile_fn, arg: the exact_sweep): decides what
 * it can of its own candidates from every tile's state, into its next.
 * Tiles may run at once: each writes only its own next. */
int wpd_exact_decide_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err);

#endif
