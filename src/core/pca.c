/* pca.c - 3x3 symmetric eigen-decomposition and PCA plane fits. */
#include "core/pca.h"

#include <math.h>
#include <string.h>

void wpd_sym3_eigen(const double a[6], double evals[3], double evecs[3][3])
{
    double m[3][3] = {{a[0], a[1], a[2]}, {a[1], a[3], a[4]}, {a[2], a[4], a[5]}};
    double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int sweep = 0; sweep < 16; sweep++) {
        double off = fabs(m[0][1]) + fabs(m[0][2]) + fabs(m[1][2]);
        double diag = fabs(m[0][0]) + fabs(m[1][1]) + fabs(m[2][2]);
        if (off <= 1e-15 * diag || off == 0)
            break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (m[p][q] == 0)
                    continue;
                double theta = (m[q][q] - m[p][p]) / (2 * m[p][q]);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; k++) { /* m = m * J */
                    double mkp = m[k][p], mkq = m[k][q];
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for (int k = 0; k < 3; k++) { /* m = J^T * m */
                    double mpk = m[p][k], mqk = m[q][k];
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
                for (int k = 0; k < 3; k++) { /* v = v * J */
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (m[order[j]][order[j]] < m[order[i]][order[i]]) {
                int t = order[i];
                order[i] = order[j];
                order[j] = t;
            }
    for (int i = 0; i < 3; i++) {
        evals[i] = m[order[i]][order[i]];
        for (int k = 0; k < 3; k++)
            evecs[i][k] = v[k][order[i]];
    }
}

/* Smallest eigenpair of a symmetric 3x3 matrix in closed form (eigenvalues
 * by the trigonometric formula, the eigenvector as the longest cross product
 * of two rows of A - lambda I). Returns 0 when that is ill-conditioned (two
 * smallest eigenvalues nearly equal), so the caller falls back to Jacobi. */
static int smallest_eigen_fast(const double a[6], double ev[3], double vec[3])
{
    double m = (a[0] + a[3] + a[5]) / 3;
    double b0 = a[0] - m, b3 = a[3] - m, b5 = a[5] - m;
    double off = a[1] * a[1] + a[2] * a[2] + a[4] * a[4];
    double p = (b0 * b0 + b3 * b3 + b5 * b5 + 2 * off) / 6;
    if (!(p > 0))
        return 0;
    double det = b0 * (b3 * b5 - a[4] * a[4]) - a[1] * (a[1] * b5 - a[4] * a[2]) +
                 a[2] * (a[1] * a[4] - b3 * a[2]);
    double sp = sqrt(p);
    double c = det / (2 * p * sp);
    c = c < -1 ? -1 : c > 1 ? 1 : c;
    double phi = acos(c) / 3;
    double hi = m + 2 * sp * cos(phi);
    double lo = m + 2 * sp * cos(phi + 2 * M_PI / 3);
    double mid = 3 * m - hi - lo;
    if (mid - lo < 1e-6 * (hi - lo))
        return 0;
    double r0[3] = {a[0] - lo, a[1], a[2]}, r1[3] = {a[1], a[3] - lo, a[4]},
           r2[3] = {a[2], a[4], a[5] - lo};
    double c01[3] = {r0[1] * r1[2] - r0[2] * r1[1], r0[2] * r1[0] - r0[0] * r1[2],
                     r0[0] * r1[1] - r0[1] * r1[0]};
    double c02[3] = {r0[1] * r2[2] - r0[2] * r2[1], r0[2] * r2[0] - r0[0] * r2[2],
                     r0[0] * r2[1] - r0[1] * r2[0]};
    double c12[3] = {r1[1] * r2[2] - r1[2] * r2[1], r1[2] * r2[0] - r1[0] * r2[2],
                     r1[0] * r2[1] - r1[1] * r2[0]};
    double n01 = c01[0] * c01[0] + c01[1] * c01[1] + c01[2] * c01[2];
    double n02 = c02[0] * c02[0] + c02[1] * c02[1] + c02[2] * c02[2];
    double n12 = c12[0] * c12[0] + c12[1] * c12[1] + c12[2] * c12[2];
    const double *best = n01 >= n02 && n01 >= n12 ? c01 : n02 >= n12 ? c02 : c12;
    double nb = fmax(n01, fmax(n02, n12));
    double scale = hi - lo;
    if (!(nb > 1e-18 * scale * scale * scale * scale))
        return 0;
    double inv = 1 / sqrt(nb);
    for (int k = 0; k < 3; k++)
        vec[k] = best[k] * inv;
    ev[0] = lo;
    ev[1] = mid;
    ev[2] = hi;
    return 1;
}

void wpd_sym3_smallest(const double a[6], double evals[3], double vec[3])
{
    if (smallest_eigen_fast(a, evals, vec))
        return;
    double evecs[3][3];
    wpd_sym3_eigen(a, evals, evecs);
    memcpy(vec, evecs[0], 3 * sizeof *vec);
}

void wpd_plane_fit(const double *xyz, const uint32_t *idx, int m, wpd_plane *pl)
{
    memset(pl, 0, sizeof *pl);
    pl->normal[2] = 1;
    if (m <= 0)
        return;
    /* Work relative to the first point: the covariance of raw coordinates far
     * from the origin loses precision. */
    const double *p0 = xyz + 3 * (size_t)(idx ? idx[0] : 0);
    double mean[3] = {0, 0, 0};
    for (int j = 0; j < m; j++) {
        const double *p = xyz + 3 * (size_t)(idx ? idx[j] : (uint32_t)j);
        for (int a = 0; a < 3; a++)
            mean[a] += p[a] - p0[a];
    }
    for (int a = 0; a < 3; a++)
        mean[a] /= m;
    for (int a = 0; a < 3; a++)
        pl->centroid[a] = p0[a] + mean[a];
    if (m < 3)
        return;
    double c[6] = {0, 0, 0, 0, 0, 0};
    for (int j = 0; j < m; j++) {
        const double *p = xyz + 3 * (size_t)(idx ? idx[j] : (uint32_t)j);
        double d0 = p[0] - p0[0] - mean[0];
        double d1 = p[1] - p0[1] - mean[1];
        double d2 = p[2] - p0[2] - mean[2];
        c[0] += d0 * d0; c[1] += d0 * d1; c[2] += d0 * d2;
        c[3] += d1 * d1; c[4] += d1 * d2; c[5] += d2 * d2;
    }
    double ev[3], vec[3][3];
    if (!smallest_eigen_fast(c, ev, vec[0]))
        wpd_sym3_eigen(c, ev, vec);
    double sum = ev[0] + ev[1] + ev[2];
    if (!(sum > 0))
        return;
    memcpy(pl->normal, vec[0], sizeof pl->normal);
    pl->variation = (ev[0] > 0 ? ev[0] : 0) / sum;
}

void wpd_tangent_frame(const double n[3], double u[3], double v[3])
{
    /* Cross n with the axis it is least aligned with. */
    double ax = fabs(n[0]), ay = fabs(n[1]), az = fabs(n[2]);
    double e[3] = {0, 0, 0};
    e[ax <= ay && ax <= az ? 0 : ay <= az ? 1 : 2] = 1;
    u[0] = n[1] * e[2] - n[2] * e[1];
    u[1] = n[2] * e[0] - n[0] * e[2];
    u[2] = n[0] * e[1] - n[1] * e[0];
    double len = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int a = 0; a < 3; a++)
        u[a] /= len;
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
}

void wpd_plane_project(const wpd_plane *pl, const double p[3], double out[3])
{
    double d = 0;
    for (int a = 0; a < 3; a++)
        d += (p[a] - pl->centroid[a]) * pl->normal[a];
    for (int a = 0; a < 3; a++)
        out[a] = p[a] - d * pl->normal[a];
}
