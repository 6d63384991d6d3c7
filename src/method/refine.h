/* refine.h - the loop that decides the next Poisson-disk radius, kept
 * apart from the passes themselves so that an out-of-core caller can drive
 * it with a count summed over all its blocks.
 *
 * A pass that keeps at least n samples is final: the exact count
 * (eliminate.h) deletes the surplus where that opens the smallest holes,
 * which keeps the coverage of a maximal Poisson sample (pruning the pass
 * at a larger radius would open holes). A pass that keeps fewer shrinks r
 * as paper eq. 5 does:
 *   count < n    r' = r (1 - R / theta1),  R = 1 - count / n,  theta1 = 1.8
 * From the second pass below n on, the step is the larger of eq. 5's and a
 * secant's: the radius where the count, growing with 1/r as it did
 * between the last two passes below n (count ~ r^-s), reaches 1.02 n, at
 * most a halving of r. Eq. 5 moves r by a share of the shortfall, and
 * where the count hardly grows as r shrinks (n near the input's size:
 * below the points' spacing a pass keeps nearly all of them whatever r)
 * it took up to 40 passes (docs/algorithm.md section 2); one eq. 5 step
 * after the first pass below n is kept, so runs that land at n in that
 * step are as before.
 * Only a first pass that overshoots far is redone, at a larger radius:
 *   count > 1.15 n (first pass)   r' = r (count / 1.06 n)^(1/2.5), at most 1.25 r0
 * An elimination sweep costs about what a Poisson pass costs and deletes a
 * fifth to a third of the samples, so a 1.5 n surplus took 5 sweeps (the
 * voxel counts behind r0 are extrapolated for a large n on a large cloud,
 * and undershoot r: 111 M real points to 10 %: 1.60 n); a second pass at
 * a radius scaled as if the count fell with r^2.5 lands between 1.06 n
 * (where it does: the test scene's 2.6) and 1.15 n (where it falls with
 * r^2: that NC Raleigh cloud, 1.60 n -> 1.22 n at the exponent 3 tried
 * first) and leaves one or two sweeps. The pass at r'
 * is a maximal Poisson sample like any other: no holes. The cap keeps r'
 * within the halo's margin (the halo is 2.5 r0: blind points lie farther
 * than 2.5 r0 - r' from the box, see resample/poisson.c). On the scans in
 * data/scans it evens the spacing (rho up by a fifth where the surplus was
 * large) for a Hausdorff distance up to 1.5 % larger (docs/algorithm.md).
 *
 * Typical use:
 *   wpd_refine st; wpd_refine_init(&st, n, r0, max_passes);
 *   do count = pass(st.r); while (wpd_refine_report(&st, count) == WPD_REFINE_AGAIN);
 */
#ifndef WPD_REFINE_H
#define WPD_REFINE_H

#include <stddef.h>

#define WPD_THETA1 1.8

typedef enum wpd_refine_status {
    WPD_REFINE_AGAIN = 0,   /* run another pass at st.r */
    WPD_REFINE_DONE = 1,    /* the last pass kept at least n */
    WPD_REFINE_GAVE_UP = 2  /* max passes reached, all below n: keep the last */
} wpd_refine_status;

#define WPD_REFINE_OVERSHOOT 1.15 /* a first pass above this x n is redone */
#define WPD_REFINE_AIM 1.06       /* ... at the radius that should keep this x n */
#define WPD_REFINE_GROW_MAX 1.25  /* ... at most this x r0 */
#define WPD_REFINE_SECANT_AIM 1.02 /* a secant step aims at this x n */

typedef struct wpd_refine {
    size_t target;        /* n */
    double r0;            /* the first radius */
    double r;             /* radius for the next pass */
    int passes;           /* passes reported */
    int max_passes;
    double below_r;       /* the last pass below n: its radius (0: none yet) */
    size_t below_count;   /* ... and its count */
} wpd_refine;

/* Starts a loop for target n (>= 1) at radius r0 (> 0). */
void wpd_refine_init(wpd_refine *st, size_t target, double r0, int max_passes);

/* Reports the count of the pass just run at st->r and decides. On
 * WPD_REFINE_AGAIN, st->r holds the next radius: smaller after an
 * undershoot, larger (at most WPD_REFINE_GROW_MAX r0) after a first pass
 * above WPD_REFINE_OVERSHOOT n. */
wpd_refine_status wpd_refine_report(wpd_refine *st, size_t count);

#endif
