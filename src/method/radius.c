/* radius.c - voxel counting and the two radius estimates. */
#include "method/radius.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/bits.h"
#include "core/grid.h"
#include "core/voxel_set.h"

static int64_t floor_index(double v)
{
    if (v < -4e18)
        v = -4e18;
    if (v > 4e18)
        v = 4e18;
    int64_t i = (int64_t)v;
    return i - (v < (double)i);
}

/* Adds the voxels of points [begin, end) to set. */
static int count_chunk(const double *xyz, size_t begin, size_t end, const int64_t base[3],
                       double inv, const int shift[2], wpd_voxel_set *set)
{
    uint64_t last = WPD_VOXEL_KEY_EMPTY;
    for (size_t i = begin; i < end; i++) {
        const double *p = xyz + 3 * i;
        /* Points lie above the base corner, so truncation is floor (up to
         * rounding at the very corner, which only moves a point by one voxel). */
        int64_t ix = (int64_t)(p[0] * inv - (double)base[0]);
        int64_t iy = (int64_t)(p[1] * inv - (double)base[1]);
        int64_t iz = (int64_t)(p[2] * inv - (double)base[2]);
        uint64_t key = (uint64_t)(ix < 0 ? 0 : ix) | ((uint64_t)(iy < 0 ? 0 : iy) << shift[0]) |
                       ((uint64_t)(iz < 0 ? 0 : iz) << shift[1]);
        if (key == last) /* scans are coherent: points often repeat a voxel */
            continue;
        last = key;
        if (wpd_voxel_set_put(set, key) < 0)
            return -1;
    }
    return 0;
}

/* Occupied voxels of edge `edge`, aligned to coordinate 0, among points
 * within [lo, hi]; 0 when the indices do not fit 63 bits. Each thread
 * counts a chunk of the points into its own set; the sets are then merged,
 * so the count (of the union) does not depend on the threads. */
static int count_scale(const double *xyz, size_t n, const double lo[3], const double hi[3],
                       double edge, int threads, size_t expect, uint64_t *m)
{
    double inv = 1.0 / edge;
    int64_t base[3];
    int b[3];
    for (int a = 0; a < 3; a++) {
        base[a] = floor_index(lo[a] * inv);
        b[a] = wpd_bits_for(floor_index(hi[a] * inv) - base[a] + 2);
    }
    *m = 0;
    if (n == 0 || b[0] + b[1] + b[2] > 63)
        return 0;
    int shift[2] = {b[0], b[0] + b[1]};
    enum { MAX_PARTS = 64 };
    int parts = threads < 1 ? 1 : threads > MAX_PARTS ? MAX_PARTS : threads;
    if (n < 100000)
        parts = 1;
    wpd_voxel_set sets[MAX_PARTS];
    memset(sets, 0, sizeof sets);
    int failed = 0;
#pragma omp parallel for num_threads(parts) schedule(static, 1) reduction(| : failed)
    for (int t = 0; t < parts; t++) {
        size_t cap = 1 << 12;
        while (cap < 2 * expect && cap < ((size_t)1 << 40))
            cap <<= 1;
        if (wpd_voxel_set_init(&sets[t], cap) < 0) {
            failed = 1;
            continue;
        }
        size_t begin = n * (size_t)t / (size_t)parts, end = n * (size_t)(t + 1) / (size_t)parts;
        failed |= count_chunk(xyz, begin, end, base, inv, shift, &sets[t]) < 0;
    }
    for (int t = 1; t < parts && !failed; t++)
        for (size_t i = 0; i < sets[t].cap && !failed; i++)
            if (sets[t].slot[i] != WPD_VOXEL_KEY_EMPTY)
                failed = wpd_voxel_set_put(&sets[0], sets[t].slot[i]) < 0;
    *m = failed ? 0 : sets[0].count;
    for (int t = 0; t < parts; t++)
        free(sets[t].slot);
    return failed ? -1 : 0;
}

/* A guess of the occupied voxels (to size the sets): as for a surface as
 * large as the box's largest face, at most one voxel per point. */
static size_t expect_voxels(size_t n, const double lo[3], const double hi[3], double edge)
{
    double e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    double face = fmax(e[0] * e[1], fmax(e[0] * e[2], e[1] * e[2]));
    double v = face / (edge * edge);
    return v < (double)n ? (size_t)v : n;
}

int wpd_voxel_counts(const double *xyz, size_t n, const double *edge, int nscales,
                     uint64_t *m, int threads, wpd_error *err)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    double lo[3], hi[3];
    wpd_point_bounds(xyz, NULL, n, lo, hi, threads);
    for (int s = 0; s < nscales; s++)
        if (count_scale(xyz, n, lo, hi, edge[s], threads, expect_voxels(n, lo, hi, edge[s]), &m[s]) < 0)
            return wpd_fail(err, WPD_E_MEMORY,
                            "radius: out of memory counting voxels of %zu points", n);
    return 0;
}

double wpd_radius_paper_formula(double m, double lv, size_t target, double lambda)
{
    if (target < 1)
        target = 1;
    return lv * sqrt(m / (lambda * (double)target * M_PI));
}

static double largest_extent(const double *xyz, size_t n, int threads)
{
    double lo[3], hi[3];
    wpd_point_bounds(xyz, NULL, n, lo, hi, threads);
    double e = 0;
    for (int a = 0; a < 3; a++)
        e = fmax(e, hi[a] - lo[a]);
    return e;
}

int wpd_radius_paper(const double *xyz, size_t n, size_t target, double lambda,
                     double voxel_frac, int threads, wpd_radius_info *out, wpd_error *err)
{
    memset(out, 0, sizeof *out);
    double extent = largest_extent(xyz, n, threads);
    double lv = voxel_frac * extent;
    if (!(lv > 0)) /* a single point, or all points equal */
        lv = 1;
    uint64_t m = 0;
    if (wpd_voxel_counts(xyz, n, &lv, 1, &m, threads, err) < 0)
        return -1;
    out->radius = wpd_radius_paper_formula((double)m, lv, target, lambda);
    out->area = (double)m * lv * lv;
    out->voxel_edge = lv;
    out->voxels = (double)m;
    out->passes = 1;
    return 0;
}

/* Where n asks for more r-voxels than the finest scales hold, those scales
 * are saturated: below the input's spacing every voxel holds one point and m
 * stays at the point count, so the log-log curve is flat there and a solution
 * on it (or beyond the finest scale) lands far below the spacing, where a
 * pass keeps nearly every point. The surface's area is still seen at the
 * finest scale that is not saturated (m below 0.9 of the largest count):
 * extrapolate from it as an area (m ~ l^-2) and never go below that. */
static double saturation_floor(const double *lx, const double *ly, int k, double lw, double x)
{
    double lmax = ly[0];
    for (int i = 1; i < k; i++)
        lmax = fmax(lmax, ly[i]);
    double sat = lmax + log(0.9);
    /* j: the finest scale below saturation; the solution must need more
     * voxels than it holds (it lies on the saturated side of it) */
    int j = 0;
    while (j < k && ly[j] >= sat)
        j++;
    if (j == 0 || j == k || !(lw >= ly[j]))
        return x;
    double xa = lx[j] + (ly[j] - lw) / 2;
    return xa > x ? xa : x;
}

int wpd_radius_from_counts(const double *edge, const uint64_t *m, int nscales, size_t target,
                           double density, wpd_radius_info *out)
{
    double want = (double)(target < 1 ? 1 : target) / density;
    double lx[WPD_MAX_SCALES], ly[WPD_MAX_SCALES];
    int k = 0;
    for (int s = 0; s < nscales && s < WPD_MAX_SCALES; s++)
        if (m[s] > 0 && edge[s] > 0) {
            lx[k] = log(edge[s]);
            ly[k++] = log((double)m[s]);
        }
    for (int i = 1; i < k; i++) /* by edge, ascending */
        for (int j = i; j > 0 && lx[j] < lx[j - 1]; j--) {
            double t = lx[j]; lx[j] = lx[j - 1]; lx[j - 1] = t;
            t = ly[j]; ly[j] = ly[j - 1]; ly[j - 1] = t;
        }
    double lw = log(want);
    int inside = 0;
    double x;
    if (k == 0) {
        memset(out, 0, sizeof *out);
        return 0;
    } else if (k == 1) {
        x = lx[0] + (ly[0] - lw) / 2; /* m ~ l^-2 */
    } else {
        /* m falls as l grows: find the segment whose counts bracket want. */
        int seg = -1;
        for (int i = 0; i + 1 < k && seg < 0; i++)
            if (ly[i] >= lw && lw >= ly[i + 1])
                seg = i;
        if (seg >= 0)
            inside = 1;
        else
            seg = lw > ly[0] ? 0 : k - 2;
        double slope = (ly[seg + 1] - ly[seg]) / (lx[seg + 1] - lx[seg]);
        if (!(slope < -0.5)) /* flat or rising counts: fall back to area-like */
            slope = inside ? slope : -2;
        if (slope == 0)
            x = 0.5 * (lx[seg] + lx[seg + 1]);
        else
            x = lx[seg] + (lw - ly[seg]) / slope;
        if (!inside && seg == 0 && x > lx[0]) /* never extrapolate the wrong way */
            x = lx[0];
        if (!inside && seg == k - 2 && x < lx[k - 1])
            x = lx[k - 1];
    }
    x = saturation_floor(lx, ly, k, lw, x);
    out->radius = exp(x);
    out->voxel_edge = out->radius;
    out->voxels = want;
    out->area = want * out->radius * out->radius;
    return inside;
}

int wpd_radius_multiscale(const double *xyz, size_t n, size_t target, double lambda,
                          double voxel_frac, double density, int threads,
                          wpd_radius_info *out, wpd_error *err)
{
    wpd_radius_info first;
    if (wpd_radius_paper(xyz, n, target, lambda, voxel_frac, threads, &first, err) < 0)
        return -1;
    double edge[WPD_MAX_SCALES];
    uint64_t m[WPD_MAX_SCALES];
    int k = 0;
    edge[k] = first.voxel_edge;
    m[k++] = (uint64_t)first.voxels;
    /* Count at the current guess, solve by log-log interpolation through
     * the counted scales, and count again at the solution until it stops
     * moving (the paper's radius is usually within a factor 1.5). */
    double guess = first.radius;
    int passes = first.passes;
    *out = first;
    for (int round = 0; round < 4 && k < WPD_MAX_SCALES; round++) {
        edge[k] = guess;
        if (wpd_voxel_counts(xyz, n, &edge[k], 1, &m[k], threads, err) < 0)
            return -1;
        k++;
        passes++;
        wpd_radius_info next;
        wpd_radius_from_counts(edge, m, k, target, density, &next);
        if (!(next.radius > 0))
            break;
        *out = next;
        if (fabs(next.radius / guess - 1) < 0.08)
            break;
        guess = next.radius;
    }
    out->passes = passes;
    return 0;
}
