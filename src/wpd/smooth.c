/* smooth.c - tangent-plane Voronoi smoothing, kept on the input surface. */
#include "wpd/smooth.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/knn.h"
#include "core/pca.h"
#include "core/voronoi.h"

/* The samples in grid cell order ("order space"): neighbouring samples
 * are neighbours in memory, which keeps every array below in cache. */
typedef struct frames {
    size_t n;        /* samples */
    int k;
    uint32_t *perm;  /* [n] order position -> sample index */
    double *pos;     /* [3n] positions, order space */
    uint32_t *nb;    /* [n*k] neighbours: order position if < n, else n + context index */
    uint8_t *cnt;    /* [n] neighbours found */
    double *uvn;     /* [9n] u, v, normal */
    uint8_t *fixed;  /* [n] 1: sharp sample with a normal neighbour */
    float *rho;      /* [n] last k-th distance to the input: next search radius */
    double *plane;   /* [9n] input plane last fitted for each sample: the point it
                        was fitted at, its centroid, its normal */
    uint8_t *fitted; /* [n] plane[] is valid */
} frames;

static void free_frames(frames *f)
{
    free(f->perm);
    free(f->pos);
    free(f->nb);
    free(f->cnt);
    free(f->uvn);
    free(f->fixed);
    free(f->rho);
    free(f->plane);
    free(f->fitted);
}

static int alloc_frames(frames *f, size_t n, int k)
{
    size_t m = n ? n : 1;
    f->n = n;
    f->k = k;
    f->perm = malloc(m * sizeof *f->perm);
    f->pos = malloc(3 * m * sizeof *f->pos);
    f->nb = malloc(m * (size_t)k * sizeof *f->nb);
    f->cnt = malloc(m);
    f->uvn = malloc(9 * m * sizeof *f->uvn);
    f->fixed = calloc(m, 1);
    f->rho = malloc(m * sizeof *f->rho);
    f->plane = malloc(9 * m * sizeof *f->plane);
    f->fitted = calloc(m, 1);
    return f->perm && f->pos && f->nb && f->cnt && f->uvn && f->fixed && f->rho && f->plane &&
                   f->fitted
               ? 0
               : -1;
}

/* Neighbour lists, normals and tangent frames, once before the iterations. */
static int build_frames(const wpd_smooth_input *in, frames *f, size_t *sharp_fixed, int threads,
                        wpd_error *err)
{
    size_t n = in->n, total = in->n + in->nctx;
    int k = f->k;
    /* Samples then context samples, one array for the neighbour grid. */
    double *all = malloc(3 * total * sizeof *all);
    uint32_t *inv = malloc((n ? n : 1) * sizeof *inv);
    wpd_grid g = {0};
    int rc = -1;
    if (!all || !inv) {
        wpd_fail(err, WPD_E_MEMORY, "smooth: out of memory for %zu samples", n);
        goto done;
    }
    memcpy(all, in->xyz, 3 * n * sizeof *all);
    if (in->nctx)
        memcpy(all + 3 * n, in->ctx_xyz, 3 * in->nctx * sizeof *all);
    /* A Poisson sample at radius r has about 13 others within 2.5 r. */
    double cell = in->spacing > 0 ? 2.6 * in->spacing : 1;
    if (wpd_grid_build_knn(&g, all, NULL, total, k, cell, threads, err) < 0)
        goto done;
    size_t m = 0;
    for (size_t s = 0; s < total; s++)
        if (g.id[s] < n) {
            inv[g.id[s]] = (uint32_t)m;
            f->perm[m++] = g.id[s];
        }
    for (size_t o = 0; o < n; o++) {
        memcpy(f->pos + 3 * o, in->xyz + 3 * (size_t)f->perm[o], 3 * sizeof *f->pos);
        f->rho[o] = (float)in->surface_hint;
    }
    size_t nsharp = 0;
#pragma omp parallel num_threads(threads) reduction(+ : nsharp)
    {
        /* First search radius from the spacing, then the k-th distance of
         * the previous (nearby) sample: only speed depends on it. */
        double hint = 2.6 * in->spacing;
#pragma omp for schedule(dynamic, 256)
        for (size_t o = 0; o < n; o++) {
            size_t i = f->perm[o];
            uint32_t *nb = f->nb + o * (size_t)k;
            double d2[WPD_KNN_MAX];
            int got = wpd_knn(&g, all + 3 * i, k, (uint32_t)i, INFINITY, hint, nb, d2);
            f->cnt[o] = (uint8_t)got;
            if (got > 0)
                hint = 1.1 * sqrt(d2[got - 1]);
            uint32_t pts[WPD_KNN_MAX + 1];
            pts[0] = (uint32_t)i;
            memcpy(pts + 1, nb, (size_t)got * sizeof *nb);
            wpd_plane pl;
            wpd_plane_fit(all, pts, got + 1, &pl);
            double *uvn = f->uvn + 9 * o;
            wpd_tangent_frame(pl.normal, uvn, uvn + 3);
            memcpy(uvn + 6, pl.normal, sizeof pl.normal);
            int sharp_with_normal_neighbour = 0;
            for (int j = 0; j < got; j++) {
                /* A neighbouring block's sample counts by its own label:
                 * a tile border must not fix an edge sample that the
                 * whole cloud would move. */
                if (in->edge && in->edge[i]) {
                    int nb_sharp = nb[j] < n ? in->edge[nb[j]]
                                             : in->ctx_edge && in->ctx_edge[nb[j] - n];
                    sharp_with_normal_neighbour |= !nb_sharp;
                }
                nb[j] = nb[j] < n ? inv[nb[j]] : nb[j]; /* to order space */
            }
            f->fixed[o] = (uint8_t)sharp_with_normal_neighbour;
            nsharp += sharp_with_normal_neighbour;
        }
    }
    *sharp_fixed = nsharp;
    rc = 0;
done:
    wpd_grid_free(&g);
    free(all);
    free(inv);
    return rc;
}

/* Moves p onto the PCA plane of the k input points nearest to it. The
 * plane is fitted anew only when p is more than half the k-th neighbour
 * distance away from where sample o's plane was last fitted: the k input
 * points span about twice that, so the old plane still describes the
 * surface under p. Measured on the NC Raleigh scan (2.27 M -> 100 K):
 * refitting beyond an eighth of that distance instead costs 50 % more
 * smoothing time (0.68 s against 0.45 s) for the same quality (mean
 * distances within 0.6 %, Voronoi and local-density CV within 0.8 %, mean
 * drift 0.314 against 0.311 input spacings). */
static void project_on_surface(const wpd_grid *surface, const frames *f, size_t o, double p[3])
{
    double *cache = f->plane + 9 * o; /* fitted at, centroid, normal */
    double reuse = 0.5 * f->rho[o];
    if (f->fitted[o]) {
        double dx = p[0] - cache[0], dy = p[1] - cache[1], dz = p[2] - cache[2];
        if (dx * dx + dy * dy + dz * dz < reuse * reuse) {
            wpd_plane pl;
            memcpy(pl.centroid, cache + 3, sizeof pl.centroid);
            memcpy(pl.normal, cache + 6, sizeof pl.normal);
            wpd_plane_project(&pl, p, p);
            return;
        }
    }
    uint32_t near[WPD_KNN_MAX];
    double d2[WPD_KNN_MAX];
    int got = wpd_knn_slots(surface, p, f->k, WPD_NO_SELF, INFINITY, 1.05 * f->rho[o], near, d2);
    if (got < 3)
        return;
    f->rho[o] = (float)sqrt(d2[got - 1]);
    double pts[3 * WPD_KNN_MAX];
    for (int j = 0; j < got; j++)
        memcpy(pts + 3 * j, surface->xyz + 3 * (size_t)near[j], 3 * sizeof(double));
    wpd_plane pl;
    wpd_plane_fit(pts, NULL, got, &pl);
    memcpy(cache, p, 3 * sizeof *cache);
    memcpy(cache + 3, pl.centroid, sizeof pl.centroid);
    memcpy(cache + 6, pl.normal, sizeof pl.normal);
    f->fitted[o] = 1;
    wpd_plane_project(&pl, p, p);
}

/* Neighbours that shape a sample's Voronoi cell. The k (13) neighbours give
 * a stable PCA normal, but in a Poisson sample the cell is bounded by its ~6
 * natural neighbours, which are almost always among the nearest 8; the
 * farther ones only reach the cell where the neighbourhood is lopsided -
 * across a crease or onto another surface (furniture over a floor, a wall
 * over the ground), where their projections pinch the cell and drag the
 * sample off its own sheet. Measured on the authors' conference room
 * (20 K -> 2 K): with all 13, Voronoi-area CV 0.260, local-density CV 0.122,
 * Hausdorff 0.430; with the nearest 8, 0.228, 0.101 and 0.265 (the release:
 * 0.257, 0.113, 0.285). */
enum { VORONOI_NEIGHBOURS = 8 };

/* New position of the sample at order position o from the previous
 * positions; returns 1 if it moved, 0 if it stays (open cell). */
static int smooth_one(const wpd_smooth_input *in, const frames *f, const double *prev, size_t o,
                      double out[3])
{
    const double *p = prev + 3 * o;
    const double *u = f->uvn + 9 * o, *v = u + 3;
    const uint32_t *nb = f->nb + o * (size_t)f->k;
    /* The cell is built from the nearest VORONOI_NEIGHBOURS of the k whose
     * normal fit defines the plane (see the constant); the release's mode
     * keeps all k, as the release does. */
    int all = f->cnt[o], m = all;
    if (in->mode != WPD_SMOOTH_VERTEX_MEAN && m > VORONOI_NEIGHBOURS)
        m = VORONOI_NEIGHBOURS;
    double q[2 * WPD_KNN_MAX], frame = 0;
    for (int j = 0; j < all; j++) {
        const double *pj = nb[j] < f->n ? prev + 3 * (size_t)nb[j]
                                        : in->ctx_xyz + 3 * (size_t)(nb[j] - f->n);
        double d[3] = {pj[0] - p[0], pj[1] - p[1], pj[2] - p[2]};
        q[2 * j] = d[0] * u[0] + d[1] * u[1] + d[2] * u[2];
        q[2 * j + 1] = d[0] * v[0] + d[1] * v[1] + d[2] * v[2];
        frame = fmax(frame, fmax(fabs(q[2 * j]), fabs(q[2 * j + 1])));
    }
    /* The frame spans all k neighbours: a cell cut by the nearest few that
     * reaches past the farthest of the k is open. */
    wpd_voronoi_cell cell;
    wpd_voronoi_cell_2d(q, m, frame, &cell);
    double c[2];
    int ok = cell.closed;
    if (in->mode == WPD_SMOOTH_COTAN)
        ok = wpd_cotan_average(q, m, &cell, c);
    else
        memcpy(c, in->mode == WPD_SMOOTH_VERTEX_MEAN ? cell.vertex_mean : cell.centroid, sizeof c);
    if (!ok) {
        memcpy(out, p, 3 * sizeof *out);
        return 0;
    }
    for (int a = 0; a < 3; a++)
        out[a] = p[a] + c[0] * u[a] + c[1] * v[a];
    if (in->surface)
        project_on_surface(in->surface, f, o, out);
    return 1;
}

/* The guarantee behind keeping samples on the surface: no sample ends
 * farther from the input than the input's own local spacing there. The
 * plane projection already holds nearly every sample to a fraction of it,
 * but a plane fit is not the surface in vegetation, at thin objects and
 * at corners; a sample whose nearest input point q is farther than
 * spacing(q) (the mean distance from q to its SPACING_K nearest input
 * neighbours, the definition `wpd metrics` reports drift against) is
 * pulled straight towards q until it is exactly that far. Returns how many
 * samples were pulled. */
enum { SPACING_K = 6 };

/* Input point nearest to p (its slot in *near) and, in *spacing, the
 * input's local spacing there - or, where that settles the test the caller
 * makes (distance <= spacing), a lower bound of it found on the way: with
 * d0 the distance from p to its nearest input point q and d1..d6 to the
 * next six, each of q's six nearest neighbours x has |q x| >= |p x| - d0,
 * and the six nearest to p other than q are no farther from p than they
 * are, so spacing(q) >= mean(d1..d6) - d0. When d0 is below that bound
 * (the margin covers rounding) one query suffices; otherwise q's own
 * neighbours give the spacing. Returns the distance from p, or -1 if the
 * grid is empty. */
static double nearest_with_spacing(const wpd_grid *surface, const double p[3], uint32_t *near,
                                   double *spacing)
{
    uint32_t nb[SPACING_K + 1];
    double d2[SPACING_K + 1];
    *spacing = 0;
    int got = wpd_knn_slots(surface, p, SPACING_K + 1, WPD_NO_SELF, INFINITY, 0, nb, d2);
    if (got < 1)
        return -1;
    *near = nb[0];
    double d0 = sqrt(d2[0]);
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

/* p rounded to the output's lattice (multiples of res per axis in the
 * block frame, which starts at an input point); unchanged where res is 0. */
static void round_to_output(const double res[3], const double p[3], double out[3])
{
    for (int a = 0; a < 3; a++)
        out[a] = res[a] > 0 ? nearbyint(p[a] / res[a]) * res[a] : p[a];
}

/* A sample on no scanned surface at the sampling's scale - an isolated
 * return, a noise spike, a lone wire point - has input neighbours sparser
 * than half the sample spacing around its starting position. Its tangent
 * plane means nothing and its Voronoi cell is as large as the gap around
 * it, so smoothing would throw it across that gap (tens of feet on the NC
 * Raleigh scan's spikes) and open a hole where it was: it keeps its
 * starting position. */
static int off_surface(const wpd_grid *surface, const double start[3], double spacing)
{
    /* A sample starts on an input point: its 7 nearest are that point and
     * the 6 that define the local spacing there. */
    uint32_t nb[SPACING_K + 1];
    double d2[SPACING_K + 1], local = 0;
    int got = wpd_knn_slots(surface, start, SPACING_K + 1, WPD_NO_SELF, INFINITY, 0, nb, d2);
    for (int j = 1; j < got; j++)
        local += sqrt(d2[j]);
    return got > 1 && local / (got - 1) > 0.5 * spacing;
}

static size_t clamp_to_surface(const wpd_grid *surface, double *pos, const double *start,
                               size_t n, double spacing, const double res[3], int threads)
{
    size_t pulled = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : pulled)
    for (size_t o = 0; o < n; o++) {
        double *p = pos + 3 * o;
        const double *p0 = start + 3 * o;
        if (p[0] == p0[0] && p[1] == p0[1] && p[2] == p0[2])
            continue; /* never moved: it is an input point */
        if (off_surface(surface, p0, spacing)) {
            memcpy(p, p0, 3 * sizeof *p);
            continue;
        }
        /* The position is judged as the output will store it. Pulling p
         * changes its nearest input point, whose spacing may be smaller: a
         * few rounds, then onto the input point itself (exact in any output:
         * it is an input point). */
        for (int round = 0;; round++) {
            uint32_t near;
            double stored[3], spacing = 0;
            round_to_output(res, p, stored);
            double d = nearest_with_spacing(surface, stored, &near, &spacing);
            if (d <= spacing) {
                memcpy(p, stored, sizeof stored);
                break;
            }
            const double *q = surface->xyz + 3 * (size_t)near;
            double f = round < 4 ? 0.99 * spacing / d : 0;
            for (int a = 0; a < 3; a++)
                p[a] = q[a] + (stored[a] - q[a]) * f;
            pulled += round == 0;
            if (f == 0)
                break;
        }
    }
    return pulled;
}

int wpd_smooth(const wpd_smooth_input *in, wpd_smooth_stats *stats, wpd_error *err)
{
    memset(stats, 0, sizeof *stats);
    size_t n = in->n;
    if (n == 0 || in->iterations <= 0)
        return 0;
    int threads = in->threads > 0 ? in->threads : omp_get_max_threads();
    double t0 = omp_get_wtime();
    int k = in->k < 3 ? 3 : in->k > WPD_KNN_MAX ? WPD_KNN_MAX : in->k;
    frames f = {0};
    double *next = malloc(3 * n * sizeof *next);
    double *start = NULL;     /* positions before smoothing */
    int rc = -1;
    if (!next || alloc_frames(&f, n, k) < 0) {
        wpd_fail(err, WPD_E_MEMORY, "smooth: out of memory for %zu samples", n);
        goto done;
    }
    if (build_frames(in, &f, &stats->sharp_fixed, threads, err) < 0)
        goto done;
    double t1 = omp_get_wtime();
    stats->normals_seconds = t1 - t0;

    double total_move = 0;
    double *prev = f.pos;
    start = malloc(3 * n * sizeof *start);
    if (!start) {
        wpd_fail(err, WPD_E_MEMORY, "smooth: out of memory for %zu samples", n);
        goto done;
    }
    memcpy(start, f.pos, 3 * n * sizeof *start);
    for (int it = 0; it < in->iterations; it++) {
        size_t open = 0;
        /* Jacobi: every sample reads prev only, so threads cannot matter. */
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : open)
        for (size_t o = 0; o < n; o++) {
            if (f.fixed[o])
                memcpy(next + 3 * o, prev + 3 * o, 3 * sizeof *next);
            else
                open += !smooth_one(in, &f, prev, o, next + 3 * o);
        }
        /* Fixed order of summation: the same total whatever the threads. */
        for (size_t o = 0; o < n; o++) {
            double dx = next[3 * o] - prev[3 * o], dy = next[3 * o + 1] - prev[3 * o + 1],
                   dz = next[3 * o + 2] - prev[3 * o + 2];
            total_move += sqrt(dx * dx + dy * dy + dz * dz);
        }
        double *t = prev;
        prev = next;
        next = t;
        stats->open_cells = open;
    }
    if (in->surface)
        stats->pulled_to_surface = clamp_to_surface(in->surface, prev, start, n, in->spacing,
                                                    in->resolution, threads);
    for (size_t o = 0; o < n; o++)
        memcpy(in->xyz + 3 * (size_t)f.perm[o], prev + 3 * o, 3 * sizeof *in->xyz);
    /* prev and next are f.pos and the scratch, in some order: free both. */
    f.pos = prev;
    free(next);
    next = NULL;
    stats->mean_move = in->spacing > 0 ? total_move / (double)n / in->spacing : 0;
    stats->smooth_seconds = omp_get_wtime() - t1;
    rc = 0;
done:
    free(next);
    free(start);
    free_frames(&f);
    return rc;
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
