/* smooth_guard.h - the two things a smoothing move must not break
 * (internal to method/smooth.c).
 *
 * Spacing. The Poisson pass leaves no two samples closer than r (r/2
 * between sharp-feature samples: the mean of the two radii); a Voronoi
 * move may close a pair up, and the projection back onto the surface may
 * too. Every iteration moves all samples at once from the previous
 * positions p (Jacobi), each sample i at most cap_i, the longest step it
 * announced before the moves (0 for one that stays; at most step_max).
 * With floor_ij = WPD_SMOOTH_KEEP x the pair's Poisson distance and slack
 * S = |p_i p_j| - floor_ij, sample i may end at q_i when for every other
 * sample j
 *   (a) |q_i - p_j| >= floor_ij + cap_j (i ends clear of wherever j goes), or
 *   (b) |q_i - p_i| <= max(S / 2, S - cap_j) (the pair shares the slack).
 * Then no pair ends closer than its floor: if either end met (a), by the
 * triangle inequality; otherwise both steps fit in S (if cap_j <= S/2, i
 * steps at most S - cap_j and j at most cap_j; the same the other way;
 * else both at most S/2). (a) lets a sample move away from a close
 * neighbour, (b) any way within the shared slack. Steps are capped, so only
 * samples within floor + 2 step_max of p_i can matter: they come from a
 * radius query on a grid over the current positions, not from the k
 * smoothing neighbours.
 *
 * Coverage. Smoothing must not open a hole: every input point x has a
 * bound B(x) = max(tau, its distance to the nearest sample before
 * smoothing) (tau: the Poisson radius), and after every iteration some
 * sample lies within B(x) of it. Before an iteration's moves, x is safe if
 * a sample j within reach satisfies |x p_j| + cap_j <= B(x): j steps at
 * most cap_j, wherever it goes (context samples and samples that stay have
 * cap 0). Otherwise x is put in the care of its nearest sample, which is
 * within B(x) (the invariant), and that sample only moves where it keeps
 * x within B(x). (Where a sample's possible ends are a few known points, as
 * in an even-spacing step, |x e| <= B(x) for each of them and for p_j
 * serves as well as the cap's test; and a sample that stays keeps the
 * points it owned within B(x) without a test.) The test involves one
 * sample's own move, so it holds in a Jacobi step whatever the others do. Hence after smoothing the Hausdorff
 * distance from the input to the samples is at most max(tau, what it was
 * before), and a point nearer than tau to the samples stays within tau.
 */
#ifndef WPD_SMOOTH_GUARD_H
#define WPD_SMOOTH_GUARD_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"
#include "core/knn.h"

/* No two samples end closer than this fraction of their Poisson distance.
 * 0.82 rather than 0.75: smoothing brings d_min down to the floor and so
 * the normalised Poisson radius rho to about this fraction of the Poisson
 * sample's; at 0.75 rho fell below 0.5 on lato270 and lato315 at 10 K
 * (0.497, 0.494). At 0.82 rho >= 0.5 in 17 of the 18 quality cases (all
 * whose Poisson sample has rho >= 0.6), 0.53-0.76; the Voronoi CV within
 * 0.7 % and the local CV within 0.2 % of 0.75's (docs/algorithm.md,
 * section 4). */
#define WPD_SMOOTH_KEEP 0.82

/* Where each sample may end this iteration when that is a short list of
 * points besides where it is (an even-spacing step: the input points it
 * may go onto, as the output stores them). The list is complete: the
 * sample ends, bit for bit, where it is or on one of them (a sample with
 * a cap above 0 has at least one). */
typedef struct wpd_step_ends {
    const double *xyz;     /* sample o's ends: xyz[3 * (o * per + j) ..], j < count[o] */
    const uint8_t *count;  /* [n] */
    int per;
} wpd_step_ends;

typedef struct wpd_spacing_guard {
    const wpd_grid *grid;   /* over pos */
    const double *pos;      /* current positions: the n samples (order space), then
                               the context samples */
    size_t n;
    const double *cap;      /* [n]: longest step each sample plans (<= step_max);
                               context samples (index >= n) stay */
    const uint8_t *half;    /* [n + nctx]: sharp-feature sample (radius r/2), or NULL */
    double r;               /* Poisson radius */
    double margin;          /* added to every floor: the output's rounding */
    double step_max;        /* longest step of one iteration */
    const wpd_step_ends *ends; /* each sample's possible ends, or NULL: anywhere
                                  within its cap (read by the coverage only) */
} wpd_spacing_guard;

/* The samples that matter to one sample's step, from its position p. */
typedef struct wpd_spacing_near {
    size_t o;
    double p[3];
    int n;
    uint32_t id[WPD_KNN_MAX];
    double d[WPD_KNN_MAX];   /* their distances from p, ascending */
} wpd_spacing_near;

/* The distance within which other samples matter, and so the cell of the
 * guard's grid. */
double wpd_spacing_reach(const wpd_spacing_guard *g);

/* Gathers the samples that matter to sample o at p (its current position). */
void wpd_spacing_gather(const wpd_spacing_guard *g, size_t o, const double p[3],
                        wpd_spacing_near *near);

/* 1 if sample o may end at q (rules (a)/(b) above, and the step within
 * its cap). */
int wpd_spacing_allows(const wpd_spacing_guard *g, const wpd_spacing_near *near,
                       const double q[3]);

typedef struct wpd_cover {
    const wpd_grid *surface; /* the input points (slot order) */
    size_t n;                /* samples; positions from n on are context samples */
    float *bound;            /* [surface->n] B(x), rounded up */
    uint32_t *owner;         /* [surface->n] a sample within B(x) of x (the nearest when
                                last looked up) */
    uint32_t *first;         /* [n + 2] the points sample o keeps this iteration are
                                slot[first[o] .. first[o + 1] - 1], in no fixed order */
    uint32_t *slot;
    size_t cap;              /* room in slot */
    size_t hinted;           /* points whose first owner the hint gave */
} wpd_cover;

/* What an earlier look at the input found: nearest[s], for the input point
 * in the surface's slot s, is the sample (by the caller's numbering)
 * strictly nearer to it than every other sample and context sample, or
 * WPD_COVER_NO_HINT; perm[o] is the caller's number of the sample at order
 * position o. The exact count finds these (eliminate.h) and so spares the
 * cover most of its first search. */
#define WPD_COVER_NO_HINT UINT32_MAX
typedef struct wpd_cover_hint {
    const uint32_t *nearest;
    const uint32_t *perm;
} wpd_cover_hint;

/* Bounds and first owners of the surface's points among the samples
 * start[0..n) (order space) and the context samples start[n..n+nctx);
 * hint (may be NULL) names some points' nearest samples, and the result
 * is the same as without it. Returns 0, or -1 with err set. */
int wpd_cover_init(wpd_cover *c, const wpd_grid *surface, const double *start, size_t n,
                   size_t nctx, double tau, const wpd_cover_hint *hint, int threads,
                   wpd_error *err);
void wpd_cover_free(wpd_cover *c);

/* Before an iteration's moves: which sample keeps which input point, from
 * the positions pos (n samples, then context samples), a grid over them,
 * every sample's cap (guard->cap) and, where given, its possible ends
 * (guard->ends), on `threads` threads (<= 0: OpenMP's default). The
 * result does not depend on the threads. Returns 0, or -1 with err set. */
int wpd_cover_update(wpd_cover *c, const wpd_spacing_guard *guard, const double *pos,
                     int threads, wpd_error *err);

/* Largest t in [0, 1] for which p + t m keeps every point sample o keeps
 * within its bound (0 if p itself does not). */
double wpd_cover_limit(const wpd_cover *c, size_t o, const double p[3], const double m[3]);

/* 1 if every point sample o keeps is within its bound of p. */
int wpd_cover_holds(const wpd_cover *c, size_t o, const double p[3]);

#endif
