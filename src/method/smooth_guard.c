/* smooth_guard.c - the spacing limit on smoothing moves (smooth_guard.h). */
#include "method/smooth_guard.h"

#include <math.h>
#include <string.h>

#include "core/knn.h"

/* Poisson distance of samples a and b, in units of r: the mean of their
 * radii (1, or 1/2 for a sharp-feature sample), as in the Poisson pass. */
static double pair_radius(const uint8_t *half, size_t a, size_t b)
{
    if (!half)
        return 1;
    return 0.5 * ((half[a] ? 0.5 : 1) + (half[b] ? 0.5 : 1));
}

/* Current position of sample (or context sample) id. */
static const double *near_pos(const wpd_spacing_guard *g, uint32_t id)
{
    return g->pos + 3 * (size_t)id;
}

double wpd_spacing_reach(const wpd_spacing_guard *g)
{
    return WPD_SMOOTH_KEEP * g->r + g->margin + 2 * g->step_max;
}

/* The longest step a sample may take against a neighbour with slack S
 * (distance minus floor) that plans steps up to cap: rule (b). */
static double allowance(double slack, double cap)
{
    return fmax(0.5 * slack, slack - cap);
}

void wpd_spacing_gather(const wpd_spacing_guard *g, size_t o, const double p[3],
                        wpd_spacing_near *near)
{
    double reach = wpd_spacing_reach(g), d2[WPD_KNN_MAX];
    near->o = o;
    memcpy(near->p, p, sizeof near->p);
    near->n = wpd_knn(g->grid, p, WPD_KNN_MAX, (uint32_t)o, reach, reach, near->id, d2);
    for (int j = 0; j < near->n; j++)
        near->d[j] = sqrt(d2[j]);
}

int wpd_spacing_allows(const wpd_spacing_guard *g, const wpd_spacing_near *near,
                       const double q[3])
{
    const double *p = near->p;
    double step = sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                       (q[2] - p[2]) * (q[2] - p[2]));
    if (step > g->cap[near->o])
        return 0;
    for (int j = 0; j < near->n; j++) {
        uint32_t id = near->id[j];
        double floor = WPD_SMOOTH_KEEP * g->r * pair_radius(g->half, near->o, id) + g->margin;
        double cap = id < g->n ? g->cap[id] : 0; /* context samples stay */
        if (step <= allowance(near->d[j] - floor, cap))
            continue; /* (b) */
        const double *pj = near_pos(g, id); /* (a) */
        double dq = 0;
        for (int a = 0; a < 3; a++)
            dq += (q[a] - pj[a]) * (q[a] - pj[a]);
        if (dq < (floor + cap) * (floor + cap))
            return 0;
    }
    /* The query stops at WPD_KNN_MAX samples: any other one is at least as
     * far as the last, and plans at most step_max. */
    if (near->n == WPD_KNN_MAX) {
        double last = near->d[near->n - 1], floor = WPD_SMOOTH_KEEP * g->r + g->margin;
        if (step > allowance(last - floor, g->step_max) && last - step < floor + g->step_max)
            return 0;
    }
    return 1;
}
