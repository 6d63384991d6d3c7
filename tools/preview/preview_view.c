/* preview_view.c - the camera of `wpd preview`: an orthographic view seen
 * from 35 degrees above the horizon, turned by one of six azimuths, fitted
 * to the points' own extent; the azimuth chosen is the preferred 30
 * degrees unless another fills the picture clearly better.
 */
#include "tools/preview/preview_internal.h"

#include <math.h>

#define AZIMUTH_STEP 30.0       /* a and a + 180 fit alike: 0 .. 150 suffice */
#define PREFERRED_AZIMUTH 1     /* WPD_PREVIEW_AZIMUTH_DEG */

static void view_angles(view *v, double azimuth_deg)
{
    const double deg = M_PI / 180;
    v->ca = cos(azimuth_deg * deg);
    v->sa = sin(azimuth_deg * deg);
    v->ce = cos(WPD_PREVIEW_ELEVATION_DEG * deg);
    v->se = sin(WPD_PREVIEW_ELEVATION_DEG * deg);
}

/* Pixels per unit that fit screen extents du x dv into a w x h rectangle. */
static double fit_scale(double du, double dv, int w, int h)
{
    double room_w = w > 2 * MARGIN + 1 ? w - 2 * MARGIN : 1;
    double room_h = h > 2 * MARGIN + 1 ? h - 2 * MARGIN : 1;
    double s = INFINITY;
    if (du > 0)
        s = room_w / du;
    if (dv > 0)
        s = fmin(s, room_h / dv);
    return isfinite(s) ? s : 1; /* a single point */
}

/* The view at azimuth_deg whose screen extents (relative coordinates) are
 * [ulo, uhi] x [vlo, vhi], centred in a w x h rectangle. */
static void view_fit(view *v, double azimuth_deg, double ulo, double uhi, double vlo, double vhi,
                     int w, int h)
{
    view_angles(v, azimuth_deg);
    v->w = w;
    v->h = h;
    double s = fit_scale(uhi - ulo, vhi - vlo, w, h);
    v->scale = s;
    v->px0 = w / 2.0 - (ulo + uhi) / 2 * s;
    v->py0 = h / 2.0 + (vlo + vhi) / 2 * s;
}

/* Extends the screen extents of every candidate azimuth by the batch's
 * points (absolute coordinates: the projection is linear, the origin is
 * subtracted afterwards). */
void preview_track_extents(panel *p, const wpd_batch *b)
{
    view v;
    for (int a = 0; a < AZIMUTHS; a++) {
        view_angles(&v, a * AZIMUTH_STEP);
        double ulo = p->ext_lo[a][0], uhi = p->ext_hi[a][0];
        double vlo = p->ext_lo[a][1], vhi = p->ext_hi[a][1];
        const double *q = b->xyz;
        const double cx = v.ca, sx = v.sa, ce = v.ce, se = v.se;
        /* vectorised: this loop is most of pass 1's work */
#pragma omp simd reduction(min : ulo, vlo) reduction(max : uhi, vhi)
        for (size_t i = 0; i < b->n; i++) {
            double x = q[3 * i], y = q[3 * i + 1], z = q[3 * i + 2];
            double u = x * cx - y * sx;
            double up = (x * sx + y * cx) * se + z * ce;
            ulo = u < ulo ? u : ulo;
            uhi = u > uhi ? u : uhi;
            vlo = up < vlo ? up : vlo;
            vhi = up > vhi ? up : vhi;
        }
        p->ext_lo[a][0] = ulo, p->ext_hi[a][0] = uhi;
        p->ext_lo[a][1] = vlo, p->ext_hi[a][1] = vhi;
    }
}

/* The candidate azimuth whose points fill the view rectangle best; the
 * preferred 30 degrees unless another fits at least 10 % larger (a long
 * strip seen end-on would waste most of the picture). */
double preview_choose_view(const panel *p, const double origin[3], int w, int h, view *v)
{
    int best = PREFERRED_AZIMUTH;
    double scale[AZIMUTHS];
    /* All scales first: comparing with scale[best] while filling the array
     * read scale[PREFERRED_AZIMUTH] before it was set (found by test-asan,
     * where the uninitialised stack value differed). */
    for (int a = 0; a < AZIMUTHS; a++)
        scale[a] = fit_scale(p->ext_hi[a][0] - p->ext_lo[a][0],
                             p->ext_hi[a][1] - p->ext_lo[a][1], w, h);
    for (int a = 0; a < AZIMUTHS; a++)
        if (scale[a] > scale[best])
            best = a;
    if (scale[PREFERRED_AZIMUTH] >= scale[best] / 1.1)
        best = PREFERRED_AZIMUTH;
    view_angles(v, best * AZIMUTH_STEP);
    double u0, v0, d0;
    project(v, origin, &u0, &v0, &d0);
    view_fit(v, best * AZIMUTH_STEP, p->ext_lo[best][0] - u0, p->ext_hi[best][0] - u0,
             p->ext_lo[best][1] - v0, p->ext_hi[best][1] - v0, w, h);
    return best * AZIMUTH_STEP;
}
