/* refine.c - radius updates of paper eq. 5 (contracts in refine.h). */
#include "method/refine.h"

#include <math.h>
#include <string.h>

void wpd_refine_init(wpd_refine *st, size_t target, double r0, int max_passes)
{
    memset(st, 0, sizeof *st);
    st->target = target < 1 ? 1 : target;
    st->r = st->r0 = r0;
    st->max_passes = max_passes < 1 ? 1 : max_passes;
}

/* The radius at which the count, growing as it did from the last pass
 * below n to this one (count ~ r^-s, s from the two), reaches
 * WPD_REFINE_SECANT_AIM n; at most a halving of r (and a halving where
 * the count did not grow). */
static double secant_step(const wpd_refine *st, size_t count)
{
    double r = st->r, half = 0.5 * r;
    if (!(st->below_r > r) || count <= st->below_count)
        return half;
    double s = log((double)count / (double)st->below_count) / log(st->below_r / r);
    double want = WPD_REFINE_SECANT_AIM * (double)st->target;
    double next = r * pow((double)count / want, 1 / s);
    return next > half ? next : half;
}

wpd_refine_status wpd_refine_report(wpd_refine *st, size_t count)
{
    st->passes++;
    double over = (double)count / (double)st->target;
    if (over > WPD_REFINE_OVERSHOOT && st->passes == 1 && st->passes < st->max_passes) {
        /* count ~ r^-2 (surfaces) .. r^-3 (volumes): not too far */
        st->r = fmin(st->r * pow(over / WPD_REFINE_AIM, 1 / 2.5), WPD_REFINE_GROW_MAX * st->r0);
        return WPD_REFINE_AGAIN;
    }
    if (count >= st->target)
        return WPD_REFINE_DONE;
    if (st->passes >= st->max_passes)
        return WPD_REFINE_GAVE_UP;
    double rate = 1 - (double)count / (double)st->target; /* R_n of eq. 5, > 0 */
    double next = st->r * (1 - rate / WPD_THETA1);
    if (st->below_r > 0)
        next = fmin(next, secant_step(st, count));
    st->below_r = st->r, st->below_count = count;
    st->r = next;
    return WPD_REFINE_AGAIN;
}
