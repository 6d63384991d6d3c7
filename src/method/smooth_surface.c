/* smooth_surface.c - keeping smoothed samples on the input surface
 * (smooth_surface.h), and measuring how far they are from it. */
#include "method/smooth_surface.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/knn.h"
#include "core/pca.h"
#include "method/smooth.h"

/* The guarantee behind keeping samples on the surface: no sample ends
 * farther from the input than the input's own local spacing there. The
 * plane projection already holds nearly every sample to a fraction of it,
 * but a plane fit is not the surface in vegetation, at thin objects and
 * at corners; a sample whose nearest input point q is farther than
 * spacing(q) (the mean distance from q to its SPACING_K nearest input
 * neighbours, the definition `wpd metrics` reports drift against) is
 * pulled straight towards q until it is that far (wpd_hold_on_surface, on
 * every position a move tries). */
enum { SPACING_K = 6 };

void wpd_surface_memo_fill(wpd_surface_memo *memo, const double at[3], const double *d2,
                           int got)
{
    if (!memo || got < SPACING_K)
        return;
    double sum = 0;
    for (int j = 0; j < SPACING_K; j++)
        sum += sqrt(d2[j]);
    memcpy(memo->at, at, sizeof memo->at);
    memo->d0 = sqrt(d2[0]);
    memo->m6 = sum / SPACING_K;
    memo->valid = 1;
}

/* Input point nearest to p (its slot in *near) and, in *spacing, the
 * input's local spacing there - or, where that settles the test the caller
 * makes (distance <= spacing), a lower bound of it found on the way: with
 * d0 the distance from p to its nearest input point q and d1..d6 to the
 * next six, each of q's six nearest neighbours x has |q x| >= |p x| - d0,
 * and the six nearest to p other than q are no farther from p than they
 * are, so spacing(q) >= mean(d1..d6) - d0. When d0 is below that bound
 * (the margin covers rounding) one query suffices; otherwise q's own
 * neighbours give the spacing. memo (may be NULL) is refilled from the
 * query (wpd_surface_memo_fill: when it found 6 points or more). Returns
 * the distance from p, or -1 if the grid is empty. */
static double nearest_with_spacing(const wpd_grid *surface, const double p[3], uint32_t *near,
                                   double *spacing, wpd_surface_memo *memo)
{
    uint32_t nb[SPACING_K + 1];
    double d2[SPACING_K + 1];
    *spacing = 0;
    int got = wpd_knn_slots(surface, p, SPACING_K + 1, WPD_NO_SELF, INFINITY, 0, nb, d2);
    if (got < 1)
        return -1;
    *near = nb[0];
    double d0 = sqrt(d2[0]);
    wpd_surface_memo_fill(memo, p, d2, got);
    if (got == SPACING_K + 1) {
        double mean = 0;
        for (int j = 1; j <= SPACING_K; j++)
            mean += sqrt(d2[j]);
        double bound = (mean / SPACING_K - d0) * (1 - 1e-9);
        if (d0 <= bound) {
            *spacing = bound;
            return d0;
        }
    }
    const double *q = surface->xyz + 3 * (size_t)*near;
    got = wpd_knn_slots(surface, q, SPACING_K, surface->id[*near], INFINITY, 0, nb, d2);
    double sum = 0;
    for (int j = 0; j < got; j++)
        sum += sqrt(d2[j]);
    *spacing = got ? sum / got : 0;
    return d0;
}

/* 1 if the memo settles that stored lies within the input's local spacing
 * of its nearest input point (smooth_surface.h; the margin covers the
 * rounding of the distances). */
static int memo_settles(const wpd_surface_memo *memo, const double stored[3])
{
    if (!memo || !memo->valid)
        return 0;
    double dx = stored[0] - memo->at[0], dy = stored[1] - memo->at[1],
           dz = stored[2] - memo->at[2];
    double e = sqrt(dx * dx + dy * dy + dz * dz);
    return 2 * memo->d0 + 3 * e <= memo->m6 * (1 - 1e-9);
}

/* p rounded to the output's lattice (multiples of res per axis in the
 * block frame, which starts at an input point); unchanged where res is 0. */
void wpd_round_to_output(const double res[3], const double p[3], double out[3])
{
    for (int a = 0; a < 3; a++)
        out[a] = res[a] > 0 ? nearbyint(p[a] / res[a]) * res[a] : p[a];
}

/* 1 if p rounds to stored, its point on the output's lattice, by at most
 * a thousandth of the lattice step on every axis: p is that lattice point
 * but for floating error (lone-star's UTM coordinates, relative to the
 * minimum corner, are a millionth of the step off). */
int wpd_on_lattice(const double res[3], const double p[3], const double stored[3])
{
    for (int a = 0; a < 3; a++)
        if (fabs(stored[a] - p[a]) > 1e-3 * res[a])
            return 0;
    return 1;
}

/* A sample on no scanned surface at the sampling's scale - an isolated
 * return, a noise spike, a lone wire point - has input neighbours sparser
 * than the samples around its starting position: the mean distance to its
 * 6 nearest input points is above ISOLATED_SPACING r, about the mean
 * distance from a Poisson sample at r to its 6 nearest samples (1.30-1.60 r
 * measured on NC Raleigh, CSite1, lato270 and lone-star tile 3 at 10 K).
 * Its tangent plane means nothing and its Voronoi cell is as large as the
 * gap around it: it keeps its starting position. (The bound was r until
 * 2026-11-27, which held every sample still where n is half the input, the
 * input then being about as sparse as r; and half of r before the coverage
 * guard kept such a sample from opening a hole: at 10 % of the input the
 * input spacing is about 0.45 r on an even surface, and half of r kept
 * 27-40 % of the samples of lato270 and lone-star_tile1 still.) */
#define ISOLATED_SPACING 1.5

int wpd_off_surface(const wpd_grid *surface, const double start[3], double spacing)
{
    /* A sample starts on an input point: its 7 nearest are that point and
     * the 6 that define the local spacing there. */
    uint32_t nb[SPACING_K + 1];
    double d2[SPACING_K + 1], local = 0;
    int got = wpd_knn_slots(surface, start, SPACING_K + 1, WPD_NO_SELF, INFINITY, 0, nb, d2);
    for (int j = 1; j < got; j++)
        local += sqrt(d2[j]);
    return got > 1 && local / (got - 1) > ISOLATED_SPACING * spacing;
}

/* Keeps a moved sample p within the input's local spacing of the input,
 * judged as the output will store it, and leaves it rounded to the
 * output's lattice. Pulling p changes its nearest input point, whose
 * spacing may be smaller: a few rounds, then onto the input point itself
 * (exact in any output: it is an input point). Returns 1 if p was pulled. */
int wpd_hold_on_surface(const wpd_grid *surface, const double res[3], wpd_surface_memo *memo,
                        double p[3])
{
    for (int round = 0;; round++) {
        uint32_t near;
        double stored[3], spacing = 0;
        wpd_round_to_output(res, p, stored);
        if (round == 0 && memo_settles(memo, stored)) {
            memcpy(p, stored, sizeof stored);
            return 0;
        }
        double d = nearest_with_spacing(surface, stored, &near, &spacing, memo);
        if (d <= spacing) {
            memcpy(p, stored, sizeof stored);
            return round > 0;
        }
        const double *q = surface->xyz + 3 * (size_t)near;
        double f = round < 4 ? 0.99 * spacing / d : 0;
        for (int a = 0; a < 3; a++)
            p[a] = q[a] + (stored[a] - q[a]) * f;
        if (f == 0)
            return 1;
    }
}

void wpd_measure_drift(const wpd_grid *surface, const double *xyz, size_t n, int k,
                       int threads, wpd_drift *out)
{
    memset(out, 0, sizeof *out);
    out->n = n;
    if (n == 0 || !surface || surface->n == 0)
        return;
    if (threads <= 0)
        threads = omp_get_max_threads();
    k = wpd_knn_clamp_k(k);
    double *r_near = malloc(n * sizeof *r_near), *r_plane = malloc(n * sizeof *r_plane);
    if (!r_near || !r_plane) {
        free(r_near);
        free(r_plane);
        return;
    }
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
    for (size_t i = 0; i < n; i++) {
        const double *p = xyz + 3 * i;
        uint32_t near[WPD_KNN_MAX];
        double d2[WPD_KNN_MAX];
        int got = wpd_knn_slots(surface, p, k, WPD_NO_SELF, INFINITY, 0, near, d2);
        double s = sqrt(M_PI * d2[got - 1] / got);
        double pts[3 * WPD_KNN_MAX];
        for (int j = 0; j < got; j++)
            memcpy(pts + 3 * j, surface->xyz + 3 * (size_t)near[j], 3 * sizeof(double));
        wpd_plane pl;
        wpd_plane_fit(pts, NULL, got, &pl);
        double dp = 0;
        for (int a = 0; a < 3; a++)
            dp += (p[a] - pl.centroid[a]) * pl.normal[a];
        r_near[i] = s > 0 ? sqrt(d2[0]) / s : 0;
        r_plane[i] = s > 0 && got >= 3 ? fabs(dp) / s : 0;
    }
    size_t beyond = 0;
    for (size_t i = 0; i < n; i++) {
        out->mean_nearest += r_near[i];
        out->mean_plane += r_plane[i];
        out->max_nearest = fmax(out->max_nearest, r_near[i]);
        out->max_plane = fmax(out->max_plane, r_plane[i]);
        beyond += r_near[i] > 1;
    }
    out->mean_nearest /= (double)n;
    out->mean_plane /= (double)n;
    out->frac_beyond = (double)beyond / (double)n;
    free(r_near);
    free(r_plane);
}
