/* crease.c - the two-plane crease test on one neighbourhood (crease.h).
 *
 * Why two planes and not a measure of spread: surface variation, the
 * former test, is as high in a tree crown or a cluster of multiple returns
 * as on a roof ridge, and labelled 40 % of an airborne scan that is mostly
 * forest. Asking for two planar faces meeting along a line keeps the
 * ridges and eaves and rejects volumes, and the line places the crease
 * to within the noise, so the band can be as narrow as the ground truth's.
 */
#include "method/crease.h"

#include <math.h>
#include <string.h>

#include "core/pca.h"

enum { MAX_POINTS = 64, MAX_ROUNDS = 6 };
/* A first split whose faces both lie farther than this many flatness
 * tolerances squared from their planes is not refined (split_along). */
#define HOPELESS 16.0

/* A plane fitted to some of the points: centroid, unit normal, and the
 * eigenvalues of their covariance (ascending). */
typedef struct face {
    double c[3], n[3], ev[3];
    int count;
} face;

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* Sums of the points of one face: count, coordinates, their products. */
typedef struct moments {
    int n;
    double s[3], ss[6];
} moments;

static inline void add_point(moments *mo, const double *q)
{
    mo->n++;
    for (int k = 0; k < 3; k++)
        mo->s[k] += q[k];
    mo->ss[0] += q[0] * q[0], mo->ss[1] += q[0] * q[1], mo->ss[2] += q[0] * q[2];
    mo->ss[3] += q[1] * q[1], mo->ss[4] += q[1] * q[2], mo->ss[5] += q[2] * q[2];
}

/* The covariance of the moments' points (the points lie within a few
 * spacings of the origin, so raw moments lose nothing that matters). */
static void covariance(const moments *mo, double c[3], double a[6])
{
    for (int k = 0; k < 3; k++)
        c[k] = mo->s[k] / mo->n;
    a[0] = mo->ss[0] / mo->n - c[0] * c[0], a[1] = mo->ss[1] / mo->n - c[0] * c[1];
    a[2] = mo->ss[2] / mo->n - c[0] * c[2], a[3] = mo->ss[3] / mo->n - c[1] * c[1];
    a[4] = mo->ss[4] / mo->n - c[1] * c[2], a[5] = mo->ss[5] / mo->n - c[2] * c[2];
}

/* The plane of the moments' points; its normal only. */
static void fit_face(const moments *mo, face *f)
{
    double a[6];
    f->count = mo->n;
    memset(f->ev, 0, sizeof f->ev);
    if (mo->n == 0)
        return;
    covariance(mo, f->c, a);
    wpd_sym3_smallest(a, f->ev, f->n);
}

/* Fits both faces to the points by their sides. */
static void fit_faces(const double *q, int m, const signed char *side, face f[2])
{
    moments mo[2];
    memset(mo, 0, sizeof mo);
    for (int i = 0; i < m; i++)
        add_point(&mo[side[i]], q + 3 * i);
    fit_face(&mo[0], &f[0]);
    fit_face(&mo[1], &f[1]);
}

static double plane_dist(const face *f, const double *q)
{
    double d[3] = {q[0] - f->c[0], q[1] - f->c[1], q[2] - f->c[2]};
    return fabs(dot(d, f->n));
}

/* One start of the two-face split, as it ended. The three-face test splits
 * the same points again with no hopeless test: it takes over the starts
 * that did not stop at that test (the same work would give the same
 * result) and resumes those that did. */
typedef struct split_try {
    int rc;      /* split_along's result */
    int gave_up; /* stopped at the hopeless test, after the first fit */
    signed char side[MAX_POINTS];
    face f[2];
} split_try;

/* Splits the points between two faces: first by the side of a principal
 * axis through the centroid, then each point to the nearer plane until no
 * point moves. Returns 0, or -1 when a face runs out of points or when
 * the first split leaves both faces rougher than `hopeless` (a mean
 * squared distance to their planes: a rough surface, not two planes; the
 * moves only refine a split that is nearly right). A try that gave up so
 * is resumed after its first fit. */
static int split_along(const double *q, int m, const double c[3], const double axis[3],
                       double hopeless, split_try *t)
{
    int resume = t->gave_up;
    t->gave_up = 0;
    for (int i = 0; !resume && i < m; i++) {
        double d[3] = {q[3 * i] - c[0], q[3 * i + 1] - c[1], q[3 * i + 2] - c[2]};
        t->side[i] = dot(d, axis) > 0;
    }
    for (int round = 0; round <= MAX_ROUNDS; round++) {
        if (!resume || round > 0) {
            fit_faces(q, m, t->side, t->f);
            if (t->f[0].count < 3 || t->f[1].count < 3)
                return t->rc = -1;
            if (round == 0 && t->f[0].ev[0] > hopeless && t->f[1].ev[0] > hopeless) {
                t->gave_up = 1;
                return t->rc = -1;
            }
        }
        int moved = 0;
        for (int i = 0; round < MAX_ROUNDS && i < m; i++) {
            signed char s = plane_dist(&t->f[1], q + 3 * i) < plane_dist(&t->f[0], q + 3 * i);
            moved += s != t->side[i];
            t->side[i] = s;
        }
        if (!moved)
            return t->rc = 0;
    }
    return t->rc = 0;
}

/* The better of the splits that start across the middle and across the
 * largest principal axis (the smaller summed squared distance to the
 * planes): 0 or 1, the try that holds it, or -1 when neither succeeded.
 * On a crease seen in a ball the middle axis runs across it; on a patch
 * longer than wide, the largest does. With `again`, t holds tries of the
 * same points already (split with a hopeless test): those are taken over
 * or resumed (split_try). */
static int split(const double *q, int m, const double c[3], double ax[3][3], double hopeless,
                 split_try t[2], int again)
{
    for (int k = 0; k < 2; k++) {
        if (!again)
            t[k].gave_up = 0;
        if (!again || t[k].gave_up)
            split_along(q, m, c, ax[k + 1], hopeless, &t[k]);
    }
    int a = t[0].rc, b = t[1].rc;
    const face *f = t[0].f, *g = t[1].f;
    if (b == 0 && (a != 0 || g[0].ev[0] * g[0].count + g[1].ev[0] * g[1].count <
                                 f[0].ev[0] * f[0].count + f[1].ev[0] * f[1].count))
        return 1;
    return a == 0 ? 0 : -1;
}

/* Whether every face is planar: RMS within tol, at most a tenth of its
 * points beyond 3 tol. */
static int planar(const double *pts, int m, const signed char *side, const face f[2], double tol)
{
    int far[2] = {0, 0};
    for (int i = 0; i < m; i++)
        far[side[i]] += plane_dist(&f[side[i]], pts + 3 * i) > 3 * tol;
    for (int s = 0; s < 2; s++)
        if (f[s].ev[0] > tol * tol || 10 * far[s] > f[s].count)
            return 0;
    return 1;
}

/* Whether each steep face (its normal more than 45 degrees from z, the
 * vertical of georeferenced scans) is a plane its own points determine:
 * at least WPD_CREASE_MIN_OWN of its points lie off the other face's
 * plane (farther than twice the flatness tolerance, beyond the ranging
 * noise), and not all of those on one line (one at least
 * WPD_CREASE_ROW_WIDTH x spacing off the line through their centroid
 * along their largest axis). An airborne survey crosses a wall in rows a
 * metre apart; a single wall row and the other face's row nearest the
 * crease lie on a plane that is no surface of the scene, and the line
 * where it meets the other face runs through that row, which is as
 * likely to lie a spacing from the crease as on it (such labels were
 * right about 40 % of the time on synth). Gentle faces are sampled from
 * above in rows a spacing apart, and there a row near the crease does belong
 * to it: a ridge seen within a small cap has one row of each roof plane
 * beyond the one along its line. */
static int own_planes(const double *q, int m, const signed char *side, const face f[2],
                      double tol, double spacing)
{
    double width2 = WPD_CREASE_ROW_WIDTH * spacing * WPD_CREASE_ROW_WIDTH * spacing;
    for (int s = 0; s < 2; s++) {
        if (fabs(f[s].n[2]) >= WPD_CREASE_STEEP_COS)
            continue;
        moments mo = {0, {0, 0, 0}, {0, 0, 0, 0, 0, 0}};
        for (int i = 0; i < m; i++)
            if (side[i] == s && plane_dist(&f[!s], q + 3 * i) > WPD_CREASE_OWN_TOL * tol)
                add_point(&mo, q + 3 * i);
        if (mo.n < WPD_CREASE_MIN_OWN)
            return 0;
        double c[3], a[6], ev[3], ax[3][3];
        covariance(&mo, c, a);
        wpd_sym3_eigen(a, ev, ax);
        int off = 0;
        for (int i = 0; i < m && !off; i++) {
            if (side[i] != s || plane_dist(&f[!s], q + 3 * i) <= WPD_CREASE_OWN_TOL * tol)
                continue;
            double d[3] = {q[3 * i] - c[0], q[3 * i + 1] - c[1], q[3 * i + 2] - c[2]};
            double t = dot(d, ax[2]);
            off = dot(d, d) - t * t > width2;
        }
        if (!off)
            return 0;
    }
    return 1;
}

/* The line where the two planes meet: direction dir (unit) and its point
 * nearest to p. Returns -1 for (nearly) parallel planes. */
static int meet(const face f[2], const double p[3], double dir[3], double at[3])
{
    cross(f[0].n, f[1].n, dir);
    double len = sqrt(dot(dir, dir));
    if (len < 1e-9)
        return -1;
    for (int k = 0; k < 3; k++)
        dir[k] /= len;
    /* The point on both planes and on the plane through p across dir:
     * x = a n0 + b n1 + c dir solves n0.x = n0.c0, n1.x = n1.c1, dir.x = dir.p. */
    double h0 = dot(f[0].n, f[0].c), h1 = dot(f[1].n, f[1].c), g = dot(f[0].n, f[1].n);
    double det = 1 - g * g;
    double a = (h0 - g * h1) / det, b = (h1 - g * h0) / det, c = dot(dir, p);
    for (int k = 0; k < 3; k++)
        at[k] = a * f[0].n[k] + b * f[1].n[k] + c * dir[k];
    return 0;
}

/* Whether each face lies on its own side of the line: within its plane,
 * at most a tenth of its points more than 3 tol beyond the line (points
 * near the line, on either face, may be nearer to the other plane). */
static int folded(const double *pts, int m, const signed char *side, const face f[2],
                  const double dir[3], const double at[3], double tol)
{
    for (int s = 0; s < 2; s++) {
        double u[3], toc[3];
        cross(dir, f[s].n, u);
        for (int k = 0; k < 3; k++)
            toc[k] = f[s].c[k] - at[k];
        double sign = dot(toc, u) >= 0 ? 1 : -1;
        int beyond = 0;
        for (int i = 0; i < m; i++) {
            if (side[i] != s)
                continue;
            double d[3] = {pts[3 * i] - at[0], pts[3 * i + 1] - at[1], pts[3 * i + 2] - at[2]};
            beyond += sign * dot(d, u) < -3 * tol;
        }
        if (10 * beyond > f[s].count)
            return 0;
    }
    return 1;
}

/* Distance from p to the line through at along dir. */
static double line_dist(const double p[3], const double dir[3], const double at[3])
{
    double d[3] = {p[0] - at[0], p[1] - at[1], p[2] - at[2]};
    double t = dot(d, dir);
    double r2 = dot(d, d) - t * t;
    return r2 > 0 ? sqrt(r2) : 0;
}

/* The spacing that sets the band: the point's, or where a face is steep
 * the smaller of it and the denser face's. A wall is sampled more sparsely
 * than the roof or ground it meets, so the nearest neighbours of a point
 * on the crease reach into the wall's gaps and overstate the spacing of
 * the surface the band is measured on (labels a spacing from the crease
 * came from that); each face of the ball around a point on the crease is
 * about a half disc of the ball's radius (its farthest point), so the
 * denser face's count gives its spacing. */
static double band_spacing(const double *q, int m, const face f[2], double spacing)
{
    if (fabs(f[0].n[2]) >= WPD_CREASE_STEEP_COS && fabs(f[1].n[2]) >= WPD_CREASE_STEEP_COS)
        return spacing;
    double r2 = 0;
    for (int i = 0; i < m; i++)
        r2 = fmax(r2, dot(q + 3 * i, q + 3 * i));
    int most = f[0].count > f[1].count ? f[0].count : f[1].count;
    return fmin(spacing, sqrt(M_PI * r2 / 2 / most));
}

/* The verdict on two planar faces of enough points (q relative to the
 * point, which is at the origin): shallow, a steep face of one row, not
 * a fold, or on the crease when within the band of their line. */
static wpd_crease_verdict two_faces(const double *q, int m, const signed char *side,
                                    const face f[2], double tol, double spacing)
{
    if (fabs(dot(f[0].n, f[1].n)) > WPD_CREASE_COS_MIN)
        return WPD_CREASE_SHALLOW;
    if (!own_planes(q, m, side, f, tol, spacing))
        return WPD_CREASE_ROW;
    double dir[3], at[3], origin[3] = {0, 0, 0};
    if (meet(f, origin, dir, at) || !folded(q, m, side, f, dir, at, tol))
        return WPD_CREASE_CROSSING;
    double band = WPD_CREASE_BAND * band_spacing(q, m, f, spacing);
    return line_dist(origin, dir, at) <= band ? WPD_CREASE_ON : WPD_CREASE_NEAR;
}

/* ---- Three faces: corners ------------------------------------------------- */

/* Fits three faces to the points by their sides (0, 1, 2). */
static void fit_faces3(const double *q, int m, const signed char *side, face f[3])
{
    moments mo[3];
    memset(mo, 0, sizeof mo);
    for (int i = 0; i < m; i++)
        add_point(&mo[side[i]], q + 3 * i);
    for (int s = 0; s < 3; s++)
        fit_face(&mo[s], &f[s]);
}

/* Each point to the nearest of the three planes until none moves. Returns
 * 0, or -1 when a face runs out of points. */
static int refine3(const double *q, int m, signed char *side, face f[3])
{
    for (int round = 0; round <= MAX_ROUNDS; round++) {
        fit_faces3(q, m, side, f);
        if (f[0].count < 3 || f[1].count < 3 || f[2].count < 3)
            return -1;
        int moved = 0;
        for (int i = 0; round < MAX_ROUNDS && i < m; i++) {
            signed char best = 0;
            double d = plane_dist(&f[0], q + 3 * i);
            for (signed char s = 1; s < 3; s++) {
                double e = plane_dist(&f[s], q + 3 * i);
                if (e < d)
                    d = e, best = s;
            }
            moved += best != side[i];
            side[i] = best;
        }
        if (!moved)
            return 0;
    }
    return 0;
}

/* A three-face split: the two-face split (without its hopeless test: a
 * corner's halves are not planes; `tries`: that split's tries with the
 * test, or NULL), then the rougher face split in two the same way, then
 * the three planes refined. Returns 0 or -1. */
static int split3(const double *q, int m, const double c[3], double ax[3][3], split_try *tries,
                  signed char *side, face f[3])
{
    split_try own[2], *t = tries ? tries : own;
    int k = split(q, m, c, ax, INFINITY, t, tries != NULL);
    if (k < 0)
        return -1;
    const face *g = t[k].f;
    memcpy(side, t[k].side, (size_t)m);
    int r = g[1].ev[0] * g[1].count > g[0].ev[0] * g[0].count;
    double sub[3 * MAX_POINTS];
    int idx[MAX_POINTS], n = 0;
    moments mo = {0, {0, 0, 0}, {0, 0, 0, 0, 0, 0}};
    for (int i = 0; i < m; i++)
        if (side[i] == r) {
            memcpy(sub + 3 * n, q + 3 * i, sizeof(double[3]));
            add_point(&mo, q + 3 * i);
            idx[n++] = i;
        }
    double sc[3], a[6], ev[3], sax[3][3];
    covariance(&mo, sc, a);
    wpd_sym3_eigen(a, ev, sax);
    split_try subt[2];
    int h = n < 6 ? -1 : split(sub, n, sc, sax, INFINITY, subt, 0);
    if (h < 0)
        return -1;
    for (int j = 0; j < n; j++)
        side[idx[j]] = subt[h].side[j] ? 2 : (signed char)r;
    return refine3(q, m, side, f);
}

/* Whether each of the three faces holds enough points and is planar (as
 * planar() for two). */
static int planar3(const double *q, int m, const signed char *side, const face f[3], double tol)
{
    int far[3] = {0, 0, 0};
    for (int i = 0; i < m; i++)
        far[side[i]] += plane_dist(&f[side[i]], q + 3 * i) > 3 * tol;
    for (int s = 0; s < 3; s++)
        if (f[s].count < WPD_CREASE_MIN_FACE || f[s].ev[0] > tol * tol || 10 * far[s] > f[s].count)
            return 0;
    return 1;
}

/* The two-face verdict on faces a and b of a three-face split, on their
 * points alone. */
static wpd_crease_verdict pair_of(const double *q, int m, const signed char *side, const face f[3],
                                  int a, int b, double tol, double spacing)
{
    double sub[3 * MAX_POINTS];
    signed char subside[MAX_POINTS];
    int n = 0;
    for (int i = 0; i < m; i++)
        if (side[i] == a || side[i] == b) {
            memcpy(sub + 3 * n, q + 3 * i, sizeof(double[3]));
            subside[n++] = side[i] == b;
        }
    face g[2] = {f[a], f[b]};
    return two_faces(sub, n, subside, g, tol, spacing);
}

/* The verdict where two planes do not describe the neighbourhood: three
 * planar faces meeting at a corner (two walls and a roof or the ground),
 * the point on the crease of any two of them; else rough. The nearest
 * verdict to "on" of the three pairs is kept (the enum's order). */
static wpd_crease_verdict three_faces(const double *q, int m, const double c[3], double ax[3][3],
                                      split_try *tries, double tol, double spacing)
{
    signed char side[MAX_POINTS];
    face f[3];
    if (split3(q, m, c, ax, tries, side, f) || !planar3(q, m, side, f, tol))
        return WPD_CREASE_ROUGH;
    wpd_crease_verdict best = WPD_CREASE_VERDICTS;
    for (int a = 0; a < 3 && best != WPD_CREASE_ON; a++)
        for (int b = a + 1; b < 3 && best != WPD_CREASE_ON; b++) {
            wpd_crease_verdict v = pair_of(q, m, side, f, a, b, tol, spacing);
            best = v < best ? v : best;
        }
    return best;
}

wpd_crease_verdict wpd_crease_test(const double *pts, int m, const double p[3], double spacing)
{
    if (m > MAX_POINTS)
        m = MAX_POINTS;
    if (m < 2 * WPD_CREASE_MIN_FACE)
        return WPD_CREASE_SMALL_FACE;
    /* Coordinates relative to p: small numbers, p at the origin. */
    double q[3 * MAX_POINTS];
    moments all = {0, {0, 0, 0}, {0, 0, 0, 0, 0, 0}};
    for (int i = 0; i < m; i++) {
        for (int k = 0; k < 3; k++)
            q[3 * i + k] = pts[3 * i + k] - p[k];
        add_point(&all, q + 3 * i);
    }
    double c[3], a[6], ev[3], ax[3][3];
    covariance(&all, c, a);
    wpd_sym3_eigen(a, ev, ax);
    double total = ev[0] + ev[1] + ev[2];
    if (!(total > 0) || ev[0] < WPD_CREASE_MIN_VARIATION * total)
        return WPD_CREASE_FLAT;
    double tol = WPD_CREASE_FLATNESS * spacing;
    if (ev[0] > WPD_CREASE_MAX_VARIATION3 * total)
        return WPD_CREASE_ROUGH;
    split_try tries[2];
    int k = split(q, m, c, ax, HOPELESS * tol * tol, tries, 0);
    if (ev[0] > WPD_CREASE_MAX_VARIATION * total) {
        /* No two faces here. Three only where a start leaves one side near
         * a plane at its first fit; both sides of both starts hopeless is
         * a volume. On NC Raleigh to 100 K with --sharp, 119,691 tests
         * take this path and the full three-face test finds 115,412 of
         * them rough; leaving here spares the Poisson pass 3-10 % of its
         * time and labels 1 of its 975 points otherwise (on the oblique
         * survey, seeds 1-10: the labels resample writes alike, those of
         * `wpd edges` but 1 of 45,978). */
        if (tries[0].gave_up && tries[1].gave_up)
            return WPD_CREASE_ROUGH;
        return three_faces(q, m, c, ax, tries, tol, spacing);
    }
    if (k < 0)
        return three_faces(q, m, c, ax, tries, tol, spacing);
    const signed char *side = tries[k].side;
    const face *f = tries[k].f;
    if (f[0].count < WPD_CREASE_MIN_FACE || f[1].count < WPD_CREASE_MIN_FACE)
        return WPD_CREASE_SMALL_FACE;
    if (!planar(q, m, side, f, tol))
        return three_faces(q, m, c, ax, tries, tol, spacing);
    return two_faces(q, m, side, f, tol, spacing);
}
