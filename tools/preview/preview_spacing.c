/* preview_spacing.c - `wpd preview`'s nearest-neighbour spacing: the
 * sample (the whole cloud, or the points inside small windows that shrink
 * when full), the exact distances within it, and quantiles.
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/knn.h"

#define WINDOWS_PER_AXIS 8        /* spacing sample windows: 8 x 8 */

/* Chooses the windows for a cloud of `points` points drawn in the box
 * [0, ext]: none when it is small enough to measure whole. */
void preview_sample_layout(spacing_sample *s, const double ext[3], uint64_t points)
{
    s->windowed = points > WPD_PREVIEW_SAMPLE_MAX;
    if (!s->windowed)
        return;
    /* the two widest axes */
    int a0 = 0, a1 = 1, a2 = 2;
    if (ext[a1] > ext[a0]) { int t = a0; a0 = a1; a1 = t; }
    if (ext[a2] > ext[a0]) { int t = a0; a0 = a2; a2 = t; }
    if (ext[a2] > ext[a1]) { int t = a1; a1 = a2; a2 = t; }
    s->axis[0] = a0;
    s->axis[1] = a1;
    /* each window holds sqrt(f) of its cell per axis, f of the points */
    double f = (WPD_PREVIEW_SAMPLE_MAX / 2.0) / (double)points;
    for (int k = 0; k < 2; k++) {
        double e = ext[s->axis[k]];
        s->cell[k] = e > 0 ? e / WINDOWS_PER_AXIS : 1;
        s->half[k] = e > 0 ? s->cell[k] * sqrt(f) / 2 : INFINITY;
    }
}

/* Distance from p to the border of its window, or -1 when p is outside
 * every window. */
static double window_border(const spacing_sample *s, const double p[3])
{
    double border = INFINITY;
    for (int k = 0; k < 2; k++) {
        if (isinf(s->half[k]))
            continue;
        double c = s->cell[k], x = p[s->axis[k]];
        double i = floor(x / c);
        if (i < 0)
            i = 0;
        if (i > WINDOWS_PER_AXIS - 1)
            i = WINDOWS_PER_AXIS - 1;
        double off = fabs(x - (i + 0.5) * c);
        if (off > s->half[k])
            return -1;
        border = fmin(border, s->half[k] - off);
    }
    return border;
}

/* The windows are full: halve their sides about their centres and keep
 * the points still inside (all points of the smaller windows are known,
 * since they lie in the larger ones). */
static void sample_shrink(spacing_sample *s)
{
    for (int k = 0; k < 2; k++)
        s->half[k] /= 2;
    size_t kept = 0;
    for (size_t i = 0; i < s->n; i++)
        if (window_border(s, s->xyz + 3 * i) >= 0) {
            memmove(s->xyz + 3 * kept, s->xyz + 3 * i, 3 * sizeof *s->xyz);
            kept++;
        }
    s->n = kept;
}

void preview_sample_add(spacing_sample *s, const double p[3])
{
    if (s->windowed) {
        if (window_border(s, p) < 0)
            return;
        while (s->n == s->cap) {
            sample_shrink(s);
            if (window_border(s, p) < 0)
                return;
        }
    }
    memcpy(s->xyz + 3 * s->n, p, 3 * sizeof *p);
    s->n++;
}

int preview_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Expected spacing of the sample's points (n >= 2), to size the kNN grid:
 * the area they cover (the windows', or the two widest extents) shared
 * among them; 1 when that is degenerate. */
static double spacing_guess(const spacing_sample *s, int threads)
{
    double lo[3], hi[3];
    wpd_point_bounds(s->xyz, NULL, s->n, lo, hi, threads);
    double area = 1;
    if (s->windowed) {
        for (int k = 0; k < 2; k++)
            area *= isinf(s->half[k]) ? hi[s->axis[k]] - lo[s->axis[k]] : 2 * s->half[k];
        area *= WINDOWS_PER_AXIS * WINDOWS_PER_AXIS;
    } else {
        double e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
        qsort(e, 3, sizeof *e, preview_cmp_double);
        area = e[2] * (e[1] > 0 ? e[1] : e[2]);
    }
    double guess = sqrt(area / (double)s->n);
    return guess > 0 && isfinite(guess) ? guess : 1;
}

/* Nearest-neighbour distance of every sample point whose neighbour is
 * certain (within its window), sorted. */
int preview_measure_spacing(panel *p, int threads, wpd_error *err)
{
    spacing_sample *s = &p->sample;
    p->nspacing = 0;
    if (s->n < 2)
        return 0;
    uint32_t *self = malloc(s->n * sizeof *self);
    uint32_t *idx = malloc(s->n * sizeof *idx);
    double *d2 = malloc(s->n * sizeof *d2);
    uint8_t *count = malloc(s->n);
    p->spacing = malloc(s->n * sizeof *p->spacing);
    wpd_grid g;
    memset(&g, 0, sizeof g);
    int rc = 0;
    if (!self || !idx || !d2 || !count || !p->spacing) {
        rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory measuring the spacing", p->path);
        goto done;
    }
    double guess = spacing_guess(s, threads);
    if (wpd_grid_build_knn(&g, s->xyz, NULL, s->n, 1, guess, threads, err)) {
        rc = -1;
        goto done;
    }
    for (size_t i = 0; i < s->n; i++)
        self[i] = (uint32_t)i;
    wpd_knn_many(&g, s->xyz, self, s->n, 1, INFINITY, idx, d2, count, threads);
    for (size_t i = 0; i < s->n; i++) {
        if (!count[i])
            continue;
        double d = sqrt(d2[i]);
        if (s->windowed && window_border(s, s->xyz + 3 * i) < d)
            continue; /* a nearer neighbour may lie outside the window */
        p->spacing[p->nspacing++] = d;
    }
    qsort(p->spacing, p->nspacing, sizeof *p->spacing, preview_cmp_double);
done:
    wpd_grid_free(&g);
    free(self);
    free(idx);
    free(d2);
    free(count);
    return rc;
}

/* Value at fraction q (0..1) of sorted v[0..n-1] (nearest rank); NaN if n == 0. */
double preview_quantile(const double *v, size_t n, double q)
{
    if (n == 0)
        return NAN;
    size_t i = (size_t)(q * (double)(n - 1) + 0.5);
    return v[i < n ? i : n - 1];
}
