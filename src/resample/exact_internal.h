/* exact.h - the exact count through tiles (internal to src/resample/):
 * coverage-aware elimination (method/eliminate.h) with the samples staying in
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
 *      (resample/poisson.c): a tile decides for certain only what the greedy
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

/* A tile's arrays of a sweep, by field: in memory all along for a cloud
 * resampled in memory; for a tiled run in files (spill/blobs.h), held only
 * while the tile is worked on (exact_fields.c), so that no array over all
 * samples or candidates stays in memory. */
typedef enum exact_field {
    /* per sample (n) */
    EF_COST,          /* uint64 squared cost bits (eliminate.h) */
    EF_NN,            /* double crowding distance */
    EF_HALF,          /* uint8 1: radius r/2 (sharp label); only when labelled */
    /* per candidate (ncand) */
    EF_CAND,          /* uint32 sample index, ascending */
    EF_CGID,          /* uint64 global index */
    EF_CXYZ,          /* 3 doubles */
    EF_CCOST,         /* double raw squared cost */
    EF_RANK,          /* uint64 rank bits */
    EF_STATE,         /* uint8 decision so far (fixed during a round) */
    EF_NEXT,          /* uint8 this round's decision */
    /* per border candidate (nborder): those within 2.25 D of the box's faces */
    EF_BIDX,          /* uint32 candidate index */
    EF_BXYZ,          /* 3 doubles */
    EF_BGID,          /* uint64 */
    EF_BCOST,         /* double raw squared cost */
    EF_BRANK,         /* uint64 */
    EF_COUNT
} exact_field;

#define EF(f) (1u << (f))
#define EF_COSTS (EF(EF_COST) | EF(EF_NN) | EF(EF_HALF))
#define EF_CANDS (EF(EF_CAND) | EF(EF_CGID) | EF(EF_CXYZ) | EF(EF_CCOST) | EF(EF_RANK))
#define EF_BORDER (EF(EF_BIDX) | EF(EF_BXYZ) | EF(EF_BGID) | EF(EF_BCOST) | EF(EF_BRANK))

/* One tile's part of a sweep. */
typedef struct exact_tile {
    size_t n;         /* its samples */
    size_t ncand;     /* its candidates */
    size_t nborder;   /* its candidates near its faces */
    size_t undecided; /* candidates still EXACT_UNDECIDED */
    size_t taken;     /* candidates EXACT_TAKEN (counted with undecided after
                         each round: once all are decided, the sweep's) */
    uint64_t *cost;
    double *nn;
    uint8_t *half;
    uint32_t *cand;
    uint64_t *cgid;
    double *cxyz;
    double *ccost;
    uint64_t *rank;
    uint8_t *state, *next;
    uint32_t *bidx;
    double *bxyz;
    uint64_t *bgid;
    double *bcost;
    uint64_t *brank;
} exact_tile;

typedef struct exact_sweep {
    wpd_run *run;
    exact_tile *tile;   /* [ntiles] */
    struct wpd_blobs *blobs; /* the fields in files (tiled), or NULL */
    double reach;       /* R */
    double conflict;    /* D: no two candidates conflict farther apart */
    int labelled;       /* samples carry sharp labels */
    uint64_t tau;       /* the candidate bound (bits of a cost_of) */
    double median;      /* the median crowding distance */
} exact_sweep;

/* Fields (exact_fields.c). hold: makes the fields of mask held (read from
 * their files; in memory they always are); keep: writes them back and lets
 * them go; let_go: lets them go unchanged; alloc: allocates them for the
 * tile's current counts (zeroed). Returns 0 or -1 with err set. */
int wpd_exact_hold(exact_sweep *sw, int t, unsigned mask, wpd_error *err);
int wpd_exact_keep(exact_sweep *sw, int t, unsigned mask, wpd_error *err);
void wpd_exact_let_go(exact_sweep *sw, int t, unsigned mask);
int wpd_exact_alloc(exact_sweep *sw, int t, unsigned mask, wpd_error *err);
/* Field f of another tile u, read-only, as it was last kept: *p points
 * at it, *copy is what to free (NULL in memory, where *p is u's own
 * array). Safe while u's own thread holds or lets go of its fields.
 * Returns 0 or -1 with err set. */
int wpd_exact_peek(const exact_sweep *sw, int u, exact_field f, void **copy, const void **p,
                   wpd_error *err);
/* Frees every field of every tile and zeroes the tiles. */
void wpd_exact_free_all(exact_sweep *sw);

/* Step 3 for tile t (a wpd_tile_fn, arg: the exact_sweep): decides what
 * it can of its own candidates from every tile's state, into its next.
 * Tiles may run at once: each writes only its own next. */
int wpd_exact_decide_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err);

#endif
