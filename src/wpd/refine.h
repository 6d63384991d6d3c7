/* refine.h - the loop that decides the next Poisson-disk radius, kept
 * apart from the passes themselves so that an out-of-core caller can drive
 * it with a count summed over all its blocks.
 *
 * A pass that keeps at least n samples is final: the exact count
 * (eliminate.h) deletes the surplus where that opens the smallest holes,
 * which keeps the coverage of a maximal Poisson sample (a pass over the
 * input at a larger radius, or pruning the pass at one, would cost more
 * or open holes). A pass that keeps fewer shrinks r as paper eq. 5 does:
 *   count < n    r' = r (1 - R / theta1),  R = 1 - count / n,  theta1 = 1.8
 * (the paper's overshoot update, eq. 6, is no longer needed).
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

typedef struct wpd_refine {
    size_t target;        /* n */
    double r;             /* radius for the next pass */
    int passes;           /* passes reported */
    int max_passes;
} wpd_refine;

/* Starts a loop for target n (>= 1) at radius r0 (> 0). */
void wpd_refine_init(wpd_refine *st, size_t target, double r0, int max_passes);

/* Reports the count of the pass just run at st->r and decides. On
 * WPD_REFINE_AGAIN, st->r holds the next (smaller) radius. */
wpd_refine_status wpd_refine_report(wpd_refine *st, size_t count);

#endif
