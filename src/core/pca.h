/* pca.h - principal component analysis of small point sets: normals,
 * tangent frames and plane fits. */
#ifndef WPD_CORE_PCA_H
#define WPD_CORE_PCA_H

#include <stdint.h>

/* Eigen-decomposition of the symmetric 3x3 matrix
 *   | a[0] a[1] a[2] |
 *   | a[1] a[3] a[4] |
 *   | a[2] a[4] a[5] |
 * (cyclic Jacobi rotations). evals ascending; evecs[i] is the unit
 * eigenvector of evals[i]. */
void wpd_sym3_eigen(const double a[6], double evals[3], double evecs[3][3]);

/* The eigenvalues of the same matrix (ascending) and the unit eigenvector
 * of the smallest: in closed form where that is well conditioned, else by
 * wpd_sym3_eigen. For plane normals in inner loops. */
void wpd_sym3_smallest(const double a[6], double evals[3], double vec[3]);

/* A plane fitted to m points by PCA. */
typedef struct wpd_plane {
    double centroid[3];
    double normal[3];     /* unit; eigenvector of the smallest eigenvalue */
    double variation;     /* surface variation lambda_min / (sum of lambdas),
                             0 for a perfect plane, 1/3 for an isotropic blob */
} wpd_plane;

/* Fits a plane to the points xyz[3*idx[j]..] for j < m (idx NULL: the first
 * m points). With m < 3 (or coincident points) the normal is +z and the
 * variation 0. */
void wpd_plane_fit(const double *xyz, const uint32_t *idx, int m, wpd_plane *pl);

/* Two unit vectors u, v with (u, v, n) orthonormal and right-handed; a
 * fixed function of n. */
void wpd_tangent_frame(const double n[3], double u[3], double v[3]);

/* p moved along the plane's normal onto the plane. */
void wpd_plane_project(const wpd_plane *pl, const double p[3], double out[3]);

#endif
