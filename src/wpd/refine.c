/* refine.c - radius updates of paper eq. 5-6. */
#include "wpd/refine.h"

#include <string.h>

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
