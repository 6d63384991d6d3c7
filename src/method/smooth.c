/* smooth.c - tangent-plane Voronoi smoothing, kept on the input surface,
 * with the Poisson spacing and the input's cover guarded (smooth_guard.h).
 *
 * Before the iterations: neighbours, normals, which samples stay (sharp,
 * no surface around them, isolated), the owners of the input points. Each
 * iteration: every sample plans its Voronoi move and announces the longest
 * step it may take; then each moves as far along its plan as the guards
 * allow, put back on the input surface. */
#include "method/smooth.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "common/hugepage.h"
#include "core/knn.h"
#include "core/knn_batch.h"
#include "core/pca.h"
#include "core/voronoi.h"
#include "method/smooth_even.h"
#include "method/smooth_guard.h"
#include "method/smooth_surface.h"

_Static_assert(WPD_SMOOTH_NO_NEAREST == WPD_COVER_NO_HINT, "one mark for no nearest sample");

/* Why a sample keeps its place through every iteration (0: it may move). */
enum {
    FREE = 0,
    STILL_SHARP,    /* sharp-feature sample with a normal (non-sharp) neighbour */
    STILL_VOLUME,   /* its neighbourhood is no surface (see SURFACE_VARIATION_MAX) */
    STILL_ISOLATED  /* no scanned surface around it at the sampling's scale */
};

/* The samples in grid cell order ("order space"): neighbouring samples
 * are neighbours in memory, which keeps every array below in cache. The
 * context samples follow the n samples in pos (index n + c), where the
 * neighbour lists and the spacing guard find them. */
typedef struct frames {
    size_t n, nctx;  /* samples, context samples */
    int k;
    uint32_t *perm;  /* [n] order position -> sample index */
    double *pos;     /* [3(n + nctx)] positions, order space, then the context */
    double *start;   /* [3n] positions before smoothing, order space */
    uint32_t *nb;    /* [n*k] neighbours: order position if < n, else n + context index */
    uint8_t *cnt;    /* [n] neighbours found */
    double *uvn;     /* [9n] u, v, normal */
    uint8_t *still;  /* [n] FREE or why the sample stays */
    uint8_t *half;   /* [n + nctx] sharp-feature sample (radius r/2), or NULL */
    uint8_t *pulled; /* [n] its position was pulled back to the input surface */
    double *plan;    /* [3n] this iteration's Voronoi move of each sample */
    double *cap;     /* [n] longest step each plans this iteration (smooth_guard.h) */
    float *rho;      /* [n] last k-th distance to the input: next search radius */
    double *plane;   /* [9n] input plane last fitted for each sample: the point it
                        was fitted at, its centroid, its normal */
    uint8_t *fitted; /* [n] plane[] is valid */
    wpd_surface_memo *memo; /* [n] each sample's last look at the input around it
                               (smooth_surface.h) */
    double *spacing; /* [n] local spacing at the previous positions (even steps) */
    wpd_even_nearest *nearest; /* [n] the neighbours that define it */
    double *ends;    /* [3 * n * WPD_EVEN_TRIES] input points an even step may go
                        onto, best first, as the output stores them */
    uint8_t *tries;  /* [n] how many */
    int even;        /* this iteration is an even-spacing step (smooth_even.h) */
} frames;

static void free_frames(frames *f)
{
    free(f->perm);
    free(f->pos);
    free(f->start);
    free(f->nb);
    free(f->cnt);
    free(f->uvn);
    free(f->still);
    free(f->half);
    free(f->pulled);
    free(f->plan);
    free(f->cap);
    free(f->rho);
    free(f->plane);
    free(f->fitted);
    free(f->memo);
    free(f->spacing);
    free(f->nearest);
    free(f->ends);
    free(f->tries);
}

/* even: even-spacing steps will run, which need arrays of their own. */
static int alloc_frames(frames *f, const wpd_smooth_input *in, int k, int even)
{
    size_t m = in->n ? in->n : 1, all = in->n + in->nctx;
    f->n = in->n;
    f->nctx = in->nctx;
    f->k = k;
    f->perm = wpd_malloc_large(m * sizeof *f->perm);
    f->pos = wpd_malloc_large(3 * (all ? all : 1) * sizeof *f->pos);
    f->start = wpd_malloc_large(3 * m * sizeof *f->start);
    f->nb = wpd_malloc_large(m * (size_t)k * sizeof *f->nb);
    f->cnt = wpd_malloc_large(m);
    f->uvn = wpd_malloc_large(9 * m * sizeof *f->uvn);
    f->still = wpd_calloc_large(m, 1);
    f->half = in->edge ? wpd_calloc_large(all ? all : 1, 1) : NULL;
    f->pulled = wpd_calloc_large(m, 1);
    f->plan = wpd_malloc_large(3 * m * sizeof *f->plan);
    f->cap = wpd_malloc_large(m * sizeof *f->cap);
    f->rho = wpd_malloc_large(m * sizeof *f->rho);
    f->plane = wpd_malloc_large(9 * m * sizeof *f->plane);
    f->fitted = wpd_calloc_large(m, 1);
    f->memo = wpd_calloc_large(m, sizeof *f->memo);
    int ok = f->perm && f->pos && f->start && f->nb && f->cnt && f->uvn && f->still &&
             (f->half || !in->edge) && f->pulled && f->plan && f->cap && f->rho && f->plane &&
             f->fitted && f->memo;
    if (!ok || !even)
        return ok ? 0 : -1;
    f->spacing = wpd_malloc_large(m * sizeof *f->spacing);
    f->nearest = wpd_malloc_large(m * sizeof *f->nearest);
    f->ends = wpd_malloc_large(3 * m * WPD_EVEN_TRIES * sizeof *f->ends);
    f->tries = wpd_malloc_large(m);
    return f->spacing && f->nearest && f->ends && f->tries ? 0 : -1;
}

/* A sample moves only where its neighbourhood is a surface: in vegetation
 * and stacked multiple returns the tangent plane is arbitrary, and a
 * Voronoi move there shuffles samples through the volume. The test is the
 * surface variation sigma = lambda_min / (sum of lambdas) of the sample and
 * its k neighbours (Pauly et al. 2002, as --sharp uses on the input).
 * Measured on Poisson samples (14 points, as here): a plane with noise of
 * 0.15 r 0.002-0.008, a sphere of radius 3 r 0.03-0.04, a 90-degree crease
 * 0.05-0.09, two sheets 1 r apart 0.05-0.12, a volume 0.19 and up (1st
 * percentile). On the scans, 0.1 evens the cells more than 0.06 (Voronoi
 * CV lower in 8 of 8 cases that move; on lone-star_tile1 at 10 K, 0.06
 * left it above --no-smooth's) and leaves the volumes still: 76 % of the
 * samples of the wooded NC Raleigh scan at 100 K. docs/algorithm.md
 * section 4. */
#define SURFACE_VARIATION_MAX 0.1

/* Normal, tangent frame and whether sample o may move, from its
 * neighbours (f->nb, f->cnt: indices into all), which then move to order
 * space. all: samples (source order) then context samples. */
static int frame_one(const wpd_smooth_input *in, frames *f, const double *all,
                     const uint32_t *inv, size_t o)
{
    size_t n = in->n, i = f->perm[o];
    int k = f->k, got = f->cnt[o];
    uint32_t *nb = f->nb + o * (size_t)k;
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
        /* A neighbouring block's sample counts by its own label: a tile
         * border must not fix an edge sample that the whole cloud would
         * move. */
        if (in->edge && in->edge[i]) {
            int nb_sharp = nb[j] < n ? in->edge[nb[j]] : in->ctx_edge && in->ctx_edge[nb[j] - n];
            sharp_with_normal_neighbour |= !nb_sharp;
        }
        nb[j] = nb[j] < n ? inv[nb[j]] : nb[j]; /* to order space */
    }
    if (sharp_with_normal_neighbour)
        f->still[o] = STILL_SHARP;
    else if (got >= 3 && pl.variation > SURFACE_VARIATION_MAX)
        f->still[o] = STILL_VOLUME;
    return sharp_with_normal_neighbour;
}

/* Neighbour lists, normals and tangent frames, once before the iterations. */
static int build_frames(const wpd_smooth_input *in, frames *f, size_t *sharp_fixed, int threads,
                        wpd_error *err)
{
    size_t n = in->n, total = in->n + in->nctx;
    /* Samples then context samples, one array for the neighbour grid. */
    double *all = wpd_malloc_large(3 * total * sizeof *all);
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
    if (wpd_grid_build_knn(&g, all, NULL, total, f->k, cell, threads, err) < 0)
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
        if (f->half)
            f->half[o] = in->edge[f->perm[o]];
    }
    memcpy(f->start, f->pos, 3 * n * sizeof *f->start);
    if (in->nctx)
        memcpy(f->pos + 3 * n, in->ctx_xyz, 3 * in->nctx * sizeof *f->pos);
    for (size_t c = 0; f->half && in->ctx_edge && c < in->nctx; c++)
        f->half[n + c] = in->ctx_edge[c];
    /* Every sample's neighbours at once, on a grid of cells twice the
     * typical k-th distance (knn_batch.h: at 1.5 times, 9 % of NC
     * Raleigh's points to 50 % had their k-th neighbour beyond the cells
     * around theirs and were searched for alone, at twice 2 %). The order
     * space stays that of the grid above. */
    double dk = wpd_knn_median_kth(&g, f->k);
    if (dk > 0 && wpd_grid_build(&g, all, NULL, total, 2 * dk, threads, err) < 0)
        goto done;
    if (wpd_knn_batch(&g, n, f->k, INFINITY, inv, f->nb, NULL, f->cnt, threads, NULL, err) < 0)
        goto done;
    size_t nsharp = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : nsharp)
    for (size_t o = 0; o < n; o++)
        nsharp += (size_t)frame_one(in, f, all, inv, o);
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
    /* The same query tells the sample's memo about the input around p:
     * holding the projected point on the surface mostly needs no query of
     * its own then (smooth_surface.h). */
    wpd_surface_memo_fill(f->memo + o, p, d2, got);
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

/* Over-relaxed Lloyd: the planned move goes OVER_RELAX times the way to
 * the cell's centre (successive over-relaxation; 1 is plain Lloyd). The
 * guards cut whatever overshoots into a neighbour's spacing or uncovers an
 * input point. On the 18 quality cases (5 iterations), against 1.0: the
 * Voronoi CV lower in 16 (by up to 6.3 %; 0.6 % higher in 1), the local
 * CV lower in 12 (by up to 0.9 %; 0.35 % higher in 1), the same Hausdorff
 * distance, rho lower by up to 4.6 %; 1.3 gained less (the Voronoi CV the
 * lowest of the four rows in 13 cases with either, all criteria met in 6
 * against 7; docs/algorithm.md, section 4). */
#define OVER_RELAX 1.5

/* The move (3D, within the tangent plane) that takes sample o from its
 * previous position OVER_RELAX times the way to the area centroid of its
 * Voronoi cell; returns 0 if the cell is open (the sample stays). */
static int cell_move(const frames *f, const double *prev, size_t o, double m[3])
{
    const double *p = prev + 3 * o;
    const double *u = f->uvn + 9 * o, *v = u + 3;
    const uint32_t *nb = f->nb + o * (size_t)f->k;
    /* The cell is built from the nearest VORONOI_NEIGHBOURS of the k whose
     * normal fit defines the plane (see the constant). */
    int all = f->cnt[o], cut = all;
    if (cut > VORONOI_NEIGHBOURS)
        cut = VORONOI_NEIGHBOURS;
    double q[2 * WPD_KNN_MAX], frame = 0;
    for (int j = 0; j < all; j++) {
        const double *pj = prev + 3 * (size_t)nb[j]; /* a sample or a context sample */
        double d[3] = {pj[0] - p[0], pj[1] - p[1], pj[2] - p[2]};
        q[2 * j] = d[0] * u[0] + d[1] * u[1] + d[2] * u[2];
        q[2 * j + 1] = d[0] * v[0] + d[1] * v[1] + d[2] * v[2];
        frame = fmax(frame, fmax(fabs(q[2 * j]), fabs(q[2 * j + 1])));
    }
    /* The frame spans all k neighbours: a cell cut by the nearest few that
     * reaches past the farthest of the k is open. */
    wpd_voronoi_cell cell;
    wpd_voronoi_cell_2d(q, cut, frame, &cell);
    const double *c = cell.centroid;
    for (int a = 0; a < 3; a++)
        m[a] = cell.closed ? OVER_RELAX * (c[0] * u[a] + c[1] * v[a]) : 0;
    return cell.closed;
}

/* Samples on no surface at their start keep it (see wpd_off_surface). */
static void mark_isolated(const wpd_smooth_input *in, frames *f, int threads)
{
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
    for (size_t o = 0; o < f->n; o++)
        if (f->still[o] == FREE && wpd_off_surface(in->surface, f->pos + 3 * o, in->spacing))
            f->still[o] = STILL_ISOLATED;
}

/* Longest step of one iteration, in units of r. Lloyd steps on a Poisson
 * sample are mostly a few hundredths of r, rarely a few tenths; the cap
 * bounds the reach of the spacing guard (0.82 r + 2 steps) and so how many
 * samples it checks. */
#define STEP_MAX 0.25

/* Reach of an even-spacing step, in units of r: the input points it may
 * move onto lie within it. At 10 % of the input a sample has one or two
 * input points within r/4 and the steps hardly moved there (lone-star
 * tile 3 and the terrain at 10 %); 0.35 gave the local CV the lowest of
 * the four quality rows in all 18 cases, 0.5 made large Jacobi steps
 * overshoot (terrain 10 K 0.1335 against 0.1275 at r/4; docs/algorithm.md
 * section 4). The spacing guard's reach follows the step of each
 * iteration (iterate). */
#define EVEN_REACH 0.35

/* A float32 PLY stores each coordinate to within r/2000 (cmd_resample
 * writes doubles where the float spacing is coarser than r/1000), which can
 * close a pair by up to 0.0017 r after the guard has judged it; LAS output
 * is judged already rounded (wpd_hold_on_surface). Units of r. */
#define STORE_MARGIN 0.002

typedef struct guards {
    wpd_spacing_guard spacing;
    wpd_grid grid;          /* over the previous positions, rebuilt each iteration */
    wpd_cover cover;        /* empty (n = 0) without the input points */
    wpd_step_ends ends;     /* where an even step's samples may go */
} guards;

enum { MOVE_FULL, MOVE_SHORTENED, MOVE_REFUSED };

/* Tries p + t m, put back on the surface, into q - or, for an even step,
 * the point `end` (then t and m are not read): 1 if the guards allow it. */
static int try_move(const wpd_smooth_input *in, frames *f, const guards *g,
                    const wpd_spacing_near *near, const double m[3], double t,
                    const double *end, double q[3])
{
    size_t o = near->o;
    int pulled = 0;
    if (end) {
        memcpy(q, end, 3 * sizeof *q); /* an input point, as stored: on the surface */
    } else {
        for (int a = 0; a < 3; a++)
            q[a] = near->p[a] + t * m[a];
        if (in->surface) {
            project_on_surface(in->surface, f, o, q);
            pulled = wpd_hold_on_surface(in->surface, in->resolution, f->memo + o, q);
        }
    }
    const double *s0 = f->start + 3 * o;
    double w2 = (q[0] - s0[0]) * (q[0] - s0[0]) + (q[1] - s0[1]) * (q[1] - s0[1]) +
                (q[2] - s0[2]) * (q[2] - s0[2]);
    double wander = WPD_SMOOTH_WANDER_MAX * g->spacing.r;
    if (w2 > wander * wander || !wpd_spacing_allows(&g->spacing, near, q) ||
        (g->cover.n && !wpd_cover_holds(&g->cover, o, q)))
        return 0;
    f->pulled[o] = (uint8_t)pulled;
    return 1;
}

/* Moves sample o from p along m (its Voronoi move) as far as the guards
 * allow: the move is first cut to the sample's cap and to what keeps its
 * input points covered along the straight path; the end point, put back on
 * the surface, is then checked for spacing and coverage, and the move
 * shortened until it passes; after the last try the sample stays. Writes
 * the position to out; returns MOVE_*. */
static int guarded_move(const wpd_smooth_input *in, frames *f, const guards *g, size_t o,
                        const double p[3], const double m[3], double out[3])
{
    static const double shorter[] = {1, 0.7, 0.5, 0.35, 0.2};
    double len = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]), t = 1;
    memcpy(out, p, 3 * sizeof *out);
    if (len <= 0)
        return MOVE_FULL;
    if (len > f->cap[o])
        t = f->cap[o] / len;
    if (g->cover.n)
        t = fmin(t, wpd_cover_limit(&g->cover, o, p, m));
    wpd_spacing_near near;
    wpd_spacing_gather(&g->spacing, o, p, &near);
    for (int a = 0; a < (int)(sizeof shorter / sizeof *shorter) && t > 0; a++)
        if (try_move(in, f, g, &near, m, t * shorter[a], NULL, out))
            return t * shorter[a] < 1 ? MOVE_SHORTENED : MOVE_FULL;
    memcpy(out, p, 3 * sizeof *out);
    return MOVE_REFUSED;
}

/* Moves sample o from p onto the best of its even-step input points that
 * the guards allow (smooth_even.h), whole: a point between the two is
 * neither an input point nor judged by the step's sum. A lesser point
 * counts as shortened; none, as refused (o stays). */
static int guarded_even_move(const wpd_smooth_input *in, frames *f, const guards *g, size_t o,
                             const double p[3], double out[3])
{
    wpd_spacing_near near;
    wpd_spacing_gather(&g->spacing, o, p, &near);
    for (int c = 0; c < f->tries[o]; c++) {
        const double *q = f->ends + 3 * (o * WPD_EVEN_TRIES + c);
        if (try_move(in, f, g, &near, NULL, 0, q, out))
            return c ? MOVE_SHORTENED : MOVE_FULL;
    }
    memcpy(out, p, 3 * sizeof *out);
    return MOVE_REFUSED;
}

/* The projection back onto the surface adds a little to a planned step:
 * the cap a sample announces to its neighbours leaves room for it. */
#define PLAN_ROOM 1.25

/* First half of an even-spacing step: every sample's move onto an input
 * point (smooth_even.h) and its length as its cap. Sharp-feature samples
 * stay: they mark the edges, at their own spacing. */
static void plan_even_moves(const wpd_smooth_input *in, frames *f, const double *prev,
                            double step_max, int threads)
{
    wpd_even_spacings(prev, f->n, f->nb, f->cnt, f->k, f->spacing, f->nearest, threads);
    wpd_even_view v = {prev, f->n, f->nb, f->cnt, f->k, f->spacing, f->nearest};
    double floor = (WPD_SMOOTH_KEEP + STORE_MARGIN) * in->spacing;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
    for (size_t o = 0; o < f->n; o++) {
        f->cap[o] = 0;
        f->tries[o] = 0;
        if (f->half && f->half[o])
            continue;
        wpd_even_limits lim = {step_max, floor, f->start + 3 * o,
                               WPD_SMOOTH_WANDER_MAX * in->spacing};
        uint32_t onto[WPD_EVEN_TRIES];
        int tries = wpd_even_candidates(&v, in->surface, o, &lim, onto);
        /* Each point as the output will store it, and the cap covers them
         * all. An input point read from the output's lattice lies on it
         * but for the floating error of its coordinates (relative to the
         * minimum corner); one that does not, or that rounding takes past
         * the step's reach (which the spacing guard relies on), is left
         * out. */
        for (int c = 0; c < tries; c++) {
            const double *x = in->surface->xyz + 3 * (size_t)onto[c];
            double *q = f->ends + 3 * (o * WPD_EVEN_TRIES + f->tries[o]);
            wpd_round_to_output(in->resolution, x, q);
            double d[3] = {q[0] - prev[3 * o], q[1] - prev[3 * o + 1], q[2] - prev[3 * o + 2]};
            double step = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (!wpd_on_lattice(in->resolution, x, q) || step > step_max)
                continue;
            f->tries[o]++;
            f->cap[o] = fmax(f->cap[o], step);
        }
    }
}

/* First half of a Voronoi step: every sample's Voronoi move and the
 * longest step it plans (0 for one that stays). Returns the open cells. */
static size_t plan_moves(frames *f, const double *prev, double step_max, int threads)
{
    size_t open = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : open)
    for (size_t o = 0; o < f->n; o++) {
        double *m = f->plan + 3 * o;
        f->cap[o] = 0;
        if (f->still[o])
            continue;
        if (!cell_move(f, prev, o, m)) {
            open++;
            continue;
        }
        f->cap[o] = fmin(step_max, PLAN_ROOM * sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]));
    }
    return open;
}

/* One Jacobi iteration from prev to next (context samples included, and
 * unchanged). Every sample reads prev and the plans only: threads cannot
 * matter. */
static int iterate(const wpd_smooth_input *in, frames *f, guards *g, const double *prev,
                   double *next, int threads, wpd_smooth_stats *st, wpd_error *err)
{
    size_t n = f->n;
    /* The spacing guard's reach follows this iteration's longest step. */
    g->spacing.step_max = (f->even ? EVEN_REACH : STEP_MAX) * in->spacing;
    if (wpd_grid_build(&g->grid, prev, NULL, n + f->nctx, wpd_spacing_reach(&g->spacing),
                       threads, err))
        return -1;
    g->spacing.grid = &g->grid;
    g->spacing.pos = prev;
    if (f->even)
        plan_even_moves(in, f, prev, g->spacing.step_max, threads);
    else
        st->open_cells = plan_moves(f, prev, g->spacing.step_max, threads);
    /* An even step's samples end where they are or on one of their tries. */
    g->spacing.ends = f->even ? &g->ends : NULL;
    if (g->cover.n && wpd_cover_update(&g->cover, &g->spacing, prev, threads, err))
        return -1;
    size_t shortened = 0, refused = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) \
    reduction(+ : shortened, refused)
    for (size_t o = 0; o < n; o++) {
        const double *p = prev + 3 * o;
        memcpy(next + 3 * o, p, 3 * sizeof *next);
        if (f->cap[o] <= 0)
            continue;
        int how = f->even ? guarded_even_move(in, f, g, o, p, next + 3 * o)
                          : guarded_move(in, f, g, o, p, f->plan + 3 * o, next + 3 * o);
        shortened += how == MOVE_SHORTENED;
        refused += how == MOVE_REFUSED;
    }
    st->shortened += shortened;
    st->refused += refused;
    return 0;
}

/* Whether step `it` of `voronoi` Voronoi and `even` even-spacing steps is an
 * even one: they alternate, a Voronoi step first, until one kind runs out.
 * An even step moves samples onto input points where the spacing is
 * uneven, which leaves cells uneven that the next Voronoi step evens, and
 * so on: on the 18 quality cases, 5 Voronoi and 4 even steps alternated
 * met every criterion in 18 (15, 17 and 17 with seeds 1-3), the same steps with the
 * even ones after the Voronoi ones in 16 (the Voronoi CV of the cases at
 * 10 % above the baselines'; docs/algorithm.md section 4). */
static int even_step(int it, int voronoi, int even)
{
    int pairs = voronoi < even ? voronoi : even;
    if (it < 2 * pairs)
        return it % 2 == 1;
    return voronoi < even;
}

/* For the tests: the cover's first owners and bounds as a search finds
 * them, against c's (which started from in->nearest). */
static int check_cover(const wpd_smooth_input *in, const frames *f, const wpd_cover *c,
                       int threads, wpd_error *err)
{
    wpd_cover searched;
    if (wpd_cover_init(&searched, in->surface, f->pos, f->n, f->nctx, in->spacing, NULL, threads,
                       err))
        return -1;
    size_t at = in->surface->n;
    for (size_t s = 0; s < in->surface->n && at == in->surface->n; s++)
        if (searched.owner[s] != c->owner[s] || searched.bound[s] != c->bound[s])
            at = s;
    wpd_cover_free(&searched);
    if (at < in->surface->n)
        return wpd_fail(err, WPD_E_USAGE, "smooth: input point %zu (slot) is owned by another "
                        "sample when searched for than the nearest sample given (a bug)", at);
    return 0;
}

/* Everything before the iterations: frames, who stays, the coverage. */
static int prepare(const wpd_smooth_input *in, frames *f, guards *g, wpd_smooth_stats *st,
                   int threads, wpd_error *err)
{
    if (build_frames(in, f, &st->sharp_fixed, threads, err) < 0)
        return -1;
    if (in->surface)
        mark_isolated(in, f, threads);
    for (size_t o = 0; o < f->n; o++) {
        st->volume_fixed += f->still[o] == STILL_VOLUME;
        st->isolated_fixed += f->still[o] == STILL_ISOLATED;
    }
    g->spacing = (wpd_spacing_guard){NULL, NULL, f->n, f->cap, f->half, in->spacing,
                                     STORE_MARGIN * in->spacing, 0, NULL}; /* step_max: iterate */
    g->ends = (wpd_step_ends){f->ends, f->tries, WPD_EVEN_TRIES};
    if (!in->surface)
        return 0;
    wpd_cover_hint hint = {in->nearest, f->perm};
    if (wpd_cover_init(&g->cover, in->surface, f->pos, f->n, f->nctx, in->spacing,
                       in->nearest ? &hint : NULL, threads, err))
        return -1;
    return in->check_nearest && in->nearest ? check_cover(in, f, &g->cover, threads, err) : 0;
}

int wpd_smooth(const wpd_smooth_input *in, wpd_smooth_stats *stats, wpd_error *err)
{
    memset(stats, 0, sizeof *stats);
    size_t n = in->n, all = in->n + in->nctx;
    /* The even-spacing steps need the input points as candidates. */
    int even = in->surface ? in->even_iterations : 0;
    if (n == 0 || in->iterations + even <= 0)
        return 0;
    int threads = in->threads > 0 ? in->threads : omp_get_max_threads();
    double t0 = omp_get_wtime();
    int k = in->k < 3 ? 3 : in->k > WPD_KNN_MAX ? WPD_KNN_MAX : in->k;
    frames f = {0};
    guards g = {0};
    double *scratch = wpd_malloc_large(3 * all * sizeof *scratch), *next = scratch;
    int rc = -1;
    if (!scratch || alloc_frames(&f, in, k, even > 0) < 0) {
        wpd_fail(err, WPD_E_MEMORY, "smooth: out of memory for %zu samples", n);
        goto done;
    }
    if (prepare(in, &f, &g, stats, threads, err))
        goto done;
    memcpy(next + 3 * n, f.pos + 3 * n, 3 * in->nctx * sizeof *next);
    stats->hinted = g.cover.hinted;
    double t1 = omp_get_wtime();
    stats->normals_seconds = t1 - t0;
    double total_move = 0, *prev = f.pos;
    for (int it = 0; it < in->iterations + even; it++) {
        f.even = even_step(it, in->iterations, even);
        if (iterate(in, &f, &g, prev, next, threads, stats, err))
            goto done;
        /* Fixed order of summation: the same total whatever the threads. */
        for (size_t o = 0; o < n; o++) {
            double dx = next[3 * o] - prev[3 * o], dy = next[3 * o + 1] - prev[3 * o + 1],
                   dz = next[3 * o + 2] - prev[3 * o + 2];
            total_move += sqrt(dx * dx + dy * dy + dz * dz);
        }
        double *t = prev;
        prev = next;
        next = t;
    }
    for (size_t o = 0; o < n; o++) {
        memcpy(in->xyz + 3 * (size_t)f.perm[o], prev + 3 * o, 3 * sizeof *in->xyz);
        stats->pulled_to_surface += f.pulled[o];
    }
    stats->mean_move = in->spacing > 0 ? total_move / (double)n / in->spacing : 0;
    stats->smooth_seconds = omp_get_wtime() - t1;
    rc = 0;
done:
    free(scratch); /* prev and next were f.pos and the scratch, in some order */
    free_frames(&f);
    wpd_grid_free(&g.grid);
    wpd_cover_free(&g.cover);
    return rc;
}
