/* refine.c - radius updates of paper eq. 5-6. */
#include "wpd/refine.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "wpd/poisson.h"

void wpd_refine_init(wpd_refine *st, size_t target, double r0, int max_passes)
{
    memset(st, 0, sizeof *st);
    st->target = target < 1 ? 1 : target;
    st->r = r0;
    st->max_passes = max_passes < 1 ? 1 : max_passes;
}

wpd_refine_status wpd_refine_report(wpd_refine *st, size_t count)
{
    double n = (double)st->target;
    st->passes++;
    st->last_r = st->r;
    st->last_count = count;
    st->superset_is_last = 0;
    if (count > st->target) {
        st->r_superset = st->r;
        st->superset_count = count;
        st->superset_is_last = 1;
    }
    if (count >= st->target && (double)count <= (1 + WPD_COUNT_TOLERANCE) * n)
        return WPD_REFINE_DONE;
    if (st->passes >= st->max_passes)
        return WPD_REFINE_GAVE_UP;
    double rate = 1 - (double)count / n; /* R_n of eq. 5 */
    if (rate > 0) {
        st->r *= 1 - rate / WPD_THETA1;
    } else {
        st->r *= 1 - rate / (WPD_THETA2 + 0.5 * st->over_steps);
        st->over_steps++;
    }
    return WPD_REFINE_AGAIN;
}

int wpd_refine_can_prune(const wpd_refine *st)
{
    return st->r_superset > 0 && st->r_superset <= st->r;
}

/* The next radius to try between r_lo (m_lo samples, too many) and r_hi
 * (m_hi, too few): where the line through both in log-log space meets
 * 1.025 target (the count falls about as a power of r), kept off the ends
 * of the bracket so that it always shrinks; the midpoint while no count
 * below target is known. */
static double next_radius(double r_lo, size_t m_lo, double r_hi, size_t m_hi, size_t target)
{
    double mid = 0.5 * (r_lo + r_hi);
    if (m_hi == 0 || m_lo <= m_hi)
        return mid;
    double slope = log((double)m_hi / (double)m_lo) / log(r_hi / r_lo);
    double r = r_lo * pow(1.025 * (double)target / (double)m_lo, 1 / slope);
    double margin = 0.1 * (r_hi - r_lo);
    if (!(r > r_lo + margin))
        return r_lo + margin;
    if (!(r < r_hi - margin))
        return r_hi - margin;
    return r;
}

long wpd_prune_to_range(const double *xyz, const uint64_t *gid, const uint32_t *cand,
                        size_t count, size_t target, double r_lo, uint64_t seed, int threads,
                        uint32_t *out, double *r_out, int *passes, wpd_error *err)
{
    for (size_t i = 0; i < count; i++)
        out[i] = cand ? cand[i] : (uint32_t)i;
    *r_out = r_lo;
    if (count == 0)
        return 0;
    /* Count falls roughly as r^-2: aim just above target first. */
    double r_first = r_lo * sqrt((double)count / (1.025 * (double)target));
    double r_hi = r_lo * sqrt((double)count / (double)target) * 1.25;
    /* One grid and one set of priorities for all the passes. */
    wpd_poisson_input in = {xyz, gid, NULL, cand, count, NULL, 0, r_first, seed, threads};
    uint32_t *kept = malloc(count * sizeof *kept);
    if (!kept)
        return wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory pruning %zu samples", count);
    wpd_poisson *ps = wpd_poisson_prepare(&in, err);
    if (!ps) {
        free(kept);
        return -1;
    }
    size_t best = count, m_lo = count, m_hi = 0; /* counts at r_lo, r_hi (0: none yet) */
    *r_out = r_lo;
    for (int it = 0; it < 30; it++) {
        /* Interpolation, and bisection every other pass: the bracket at
         * least halves every two passes whatever the shape of the counts. */
        double r = it == 0       ? r_first
                   : it % 2 == 1 ? next_radius(r_lo, m_lo, r_hi, m_hi, target)
                                 : 0.5 * (r_lo + r_hi);
        long m = wpd_poisson_run(ps, r, kept, err);
        if (m < 0) {
            wpd_poisson_release(ps);
            free(kept);
            return -1;
        }
        if (passes)
            (*passes)++;
        if ((size_t)m < target) {
            r_hi = r;
            m_hi = (size_t)m;
            continue;
        }
        r_lo = r;
        m_lo = (size_t)m;
        best = (size_t)m;
        *r_out = r;
        memcpy(out, kept, best * sizeof *out);
        if ((double)m <= (1 + WPD_COUNT_TOLERANCE) * (double)target)
            break;
    }
    wpd_poisson_release(ps);
    free(kept);
    return (long)best;
}
