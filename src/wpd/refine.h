/* refine.h - the loop that decides the next Poisson-disk radius (paper
 * eq. 5-6), kept apart from the passes themselves so that an out-of-core
 * caller can drive it with a count summed over all its blocks.
 *
 * With R = 1 - count / n:
 *   count < n         r' = r (1 - R / theta1)             theta1 = 1.8
 *   count > 1.05 n    r' = r (1 - R / (theta2 + mu))      theta2 = 3.0
 *   otherwise         done.
 * mu = 0.5 k where k counts the overshooting passes so far (the authors'
 * release; the paper's text writes mu = (|P'| - n) / 2, which would stall
 * the update for any large count), so repeated overshoots take ever
 * smaller steps and the loop cannot oscillate for ever.
 *
 * Typical use:
 *   wpd_refine st; wpd_refine_init(&st, n, r0, max_passes);
 *   do { count = pass(st.r, wpd_refine_can_prune(&st) ? previous : input); }
 *   while (wpd_refine_report(&st, count) == WPD_REFINE_AGAIN);
 */
#ifndef WPD_REFINE_H
#define WPD_REFINE_H

#include <stdint.h>

#include "common/error.h"

#include <stddef.h>

#define WPD_THETA1 1.8
#define WPD_THETA2 3.0
#define WPD_COUNT_TOLERANCE 0.05

typedef enum wpd_refine_status {
    WPD_REFINE_AGAIN = 0,   /* run another pass at st.r */
    WPD_REFINE_DONE = 1,    /* the last pass landed in [n, 1.05 n] */
    WPD_REFINE_GAVE_UP = 2  /* max passes reached; use the best pass (see below) */
} wpd_refine_status;

typedef struct wpd_refine {
    size_t target;        /* n */
    double r;             /* radius for the next pass */
    int passes;           /* passes reported */
    int max_passes;
    int over_steps;       /* overshooting passes so far (the release's k) */
    double r_superset;    /* radius of the latest pass with count > n, or 0 */
    size_t superset_count;/* its count */
    double last_r;        /* radius of the latest pass */
    size_t last_count;    /* and its count */
    int superset_is_last; /* 1 when the latest pass was the latest overshoot */
} wpd_refine;

/* Starts a loop for target n (>= 1) at radius r0 (> 0). */
void wpd_refine_init(wpd_refine *st, size_t target, double r0, int max_passes);

/* Reports the count of the pass just run at st->r and decides. On
 * WPD_REFINE_AGAIN, st->r holds the next radius. On WPD_REFINE_GAVE_UP the
 * caller should keep the latest overshooting pass (count > n, to be cut down
 * by the exact count) if r_superset > 0, else the latest pass. */
wpd_refine_status wpd_refine_report(wpd_refine *st, size_t count);

/* 1 if the next pass (at st->r) may prune the result of the latest
 * overshooting pass instead of the full input: its radius is not larger
 * than st->r, so its samples are a superset candidate list. */
int wpd_refine_can_prune(const wpd_refine *st);

#endif

/* Settles an overshooting pass by pruning it: Poisson passes over its
 * samples cand[0..count-1] (indices into xyz/gid; same priorities) at
 * radii above r_lo, its radius, aimed by log-log interpolation between the
 * bracketing counts (bisection every other pass) until a count lands in
 * [target, 1.05 target] (at most 30 passes). A pruned set keeps the
 * Poisson property at its larger radius. Writes the best subset with at
 * least target samples (ascending) to out (room for count) and returns its
 * size; when no radius kept target or more, out = cand. *r_out gets the
 * radius of that subset, *passes (may be NULL) is incremented per pass.
 * Returns -1 with err set when out of memory. */
long wpd_prune_to_range(const double *xyz, const uint64_t *gid, const uint32_t *cand,
                        size_t count, size_t target, double r_lo, uint64_t seed, int threads,
                        uint32_t *out, double *r_out, int *passes, wpd_error *err);
