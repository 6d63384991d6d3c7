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
 * neighbouring blocks (fixed) have radius r and are never removed (the
 * three-valued pass below can also give them their labels).
 */
#ifndef WPD_POISSON_H
#define WPD_POISSON_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"

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
/* As wpd_poisson_prepare, on a grid the caller built over exactly the
 * candidates (wpd_grid_build with in->xyz, in->cand and in->ncand), with
 * any cell: no grid of its own is built, ever. The grid is borrowed for
 * the life of the context. Cells much smaller than r cost more column
 * look-ups per scan but scan fewer points than cells of r; the kept set
 * does not depend on the grid. (An in-memory run shares its surface grid,
 * built anyway for smoothing, instead of building a second one over the
 * whole cloud.) */
wpd_poisson *wpd_poisson_prepare_on(const wpd_poisson_input *in, const wpd_grid *grid,
                                    wpd_error *err);
/* One pass at radius r (> 0), as wpd_poisson_pass. */
long wpd_poisson_run(wpd_poisson *ps, double r, uint32_t *out, wpd_error *err);
/* Sharp labels on demand. The edge array (wpd_poisson_input.edge) may hold
 * WPD_LABEL_UNKNOWN for points whose label the pass asks of a labeller
 * only where it needs it: for a slot it decides, and for one that lies
 * between the conflict distances of radius r/2 and r from a kept point (a
 * point removed if its radius is r, and only asked for when the pass
 * reaches it, unless a nearer kept point removes it first). On NC Raleigh
 * to 100 K that is about a fifth of the points (docs/algorithm.md section
 * 5, Cost); the samples are those of the labels given in full. The
 * labeller returns point's label (0 or 1) and must be safe to call from
 * the pass's threads at once for distinct points (it is asked once per
 * point and pass context, and never for a blind one). */
#define WPD_LABEL_UNKNOWN 2
typedef int (*wpd_labeller)(void *ctx, uint32_t point);
/* Sets the labeller of a context; a pass over UNKNOWN labels without one
 * fails. */
void wpd_poisson_set_labeller(wpd_poisson *ps, wpd_labeller fn, void *ctx);

/* Frees a context; NULL is fine. */
void wpd_poisson_release(wpd_poisson *ps);

/* Input of the three-valued pass: a block's input plus what it does not
 * know. (A separate struct rather than new fields of wpd_poisson_input:
 * trailing fields would make every positional initialiser of that struct
 * warn under -Wextra, -Wmissing-field-initializers.) */
typedef struct wpd_poisson_certain_input {
    wpd_poisson_input base;
    const uint8_t *blind;      /* per point, indexed like base.xyz (read for
                                  the candidates only): 1 = points the block
                                  cannot see may lie within r of it, and its
                                  edge label may be wrong; NULL: none */
    const uint8_t *fixed_edge; /* per fixed point: 1 = sharp-feature sample,
                                  radius r/2; NULL: every fixed point r */
    const uint8_t *wanted;     /* per point, indexed like base.xyz: 1 = the caller
                                  needs this candidate's decision; 0 = decide it only
                                  where a wanted one depends on it (a tile's halo
                                  points), else report it UNKNOWN; NULL: all wanted */
} wpd_poisson_certain_input;

/* Three-valued pass, for a block that sees only part of the cloud: every
 * candidate gets a decision that is either certain (KEPT or REMOVED) or
 * UNKNOWN. Visiting the candidates in priority order, a candidate is
 *   REMOVED if a fixed point, or a KEPT candidate of smaller priority, lies
 *           within conflict distance - a blind candidate counted at radius
 *           r/2, the smallest its unknown label allows;
 *   UNKNOWN else, if it is blind, or an UNKNOWN candidate of smaller
 *           priority lies within conflict distance - a blind one counted
 *           at radius r, the largest its label allows;
 *   KEPT    otherwise.
 * UNKNOWN candidates remove nothing. Blind candidates are never scanned:
 * one of smaller priority that is not yet REMOVED when a candidate is
 * decided counts as UNKNOWN, so a candidate may be UNKNOWN where the rules
 * above decide it (never KEPT or REMOVED where they say otherwise).
 *
 * Guarantee. Call "reference" the one-block pass over the whole cloud with
 * the true labels (wpd_poisson_pass over every point, no fixed points). If
 *   (a) every fixed point is kept by the reference, with its true label in
 *       fixed_edge (fixed_edge NULL: they must all be normal points);
 *   (b) every point the reference keeps that lies closer than r (the run's
 *       radius) to a non-blind candidate is a candidate or a fixed point;
 *   (c) every non-blind candidate has its true label in edge;
 * then every KEPT candidate is kept by the reference and every REMOVED one
 * is removed by it, blind candidates included (proof in poisson_certain.c).
 * For a tile: with candidates = its own points and the undecided halo
 * points within H of its box, blind = those at H - r or more from the box,
 * fixed = the kept points of finished tiles within H + r, (b) holds; with
 * labels from wpd_detect_sharp_capped with cap c over own + halo points,
 * which look WPD_SHARP_DEPTH c far (method/sharp.h), and blind = those at
 * H - max(r, WPD_SHARP_DEPTH c) or more, (c) holds. Re-running every tile that has UNKNOWN own points, with the
 * others' certain decisions as fixed (KEPT) or dropped (REMOVED) points and
 * their UNKNOWN ones as candidates, settles at least the UNKNOWN point of
 * smallest priority of the whole cloud in each round (its tile sees only
 * certain points of smaller priority, and own points are not blind when
 * H > r), so the tiles reach the reference in finitely many rounds.
 *
 * Writes the KEPT candidates' point indices to kept and the UNKNOWN ones to
 * unknown (each with room for ncand), both ascending, and their count to
 * *nunknown; every other candidate is REMOVED. Returns how many were kept,
 * or -1 with err set. With blind NULL it is wpd_poisson_pass on in->base
 * (the same code, *nunknown = 0) but for the fixed labels. */
long wpd_poisson_pass_certain(const wpd_poisson_certain_input *in, uint32_t *kept,
                              uint32_t *unknown, size_t *nunknown, wpd_error *err);

/* A context (as wpd_poisson_prepare; the arrays of *in are borrowed too)
 * for several three-valued passes. wpd_poisson_run on it is the two-valued
 * pass (blind flags ignored, fixed labels used); the other functions above
 * apply as they are.
 * Returns NULL with err set on failure. */
wpd_poisson *wpd_poisson_prepare_certain(const wpd_poisson_certain_input *in, wpd_error *err);

/* One three-valued pass at radius r (> 0) on a context, as
 * wpd_poisson_pass_certain; on a context from wpd_poisson_prepare (no blind
 * flags) it is wpd_poisson_run with *nunknown = 0. */
long wpd_poisson_run_certain(wpd_poisson *ps, double r, uint32_t *kept, uint32_t *unknown,
                             size_t *nunknown, wpd_error *err);

#endif
