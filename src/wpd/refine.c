/* refine.c - radius updates of paper eq. 5. */
#include "wpd/refine.h"

#include <math.h>
#include <string.h>

void wpd_refine_init(wpd_refine *st, size_t target, double r0, int max_passes)
{
    memset(st, 0, sizeof *st);
    st->target = target < 1 ? 1 : target;
    st->r = st->r0 = r0;
    st->max_passes = max_passes < 1 ? 1 : max_passes;
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
    st->r *= 1 - rate / WPD_THETA1;
    return WPD_REFINE_AGAIN;
}
