/* metrics.h - `wpd metrics ORIGINAL RESAMPLED [--json]`: the geometric
 * quality and density measures of the paper's experiments, for a resampled
 * cloud R (n points) against its original O.
 *
 * Formulas (d(p, S) = Euclidean distance from p to the nearest point of S;
 * NN_k(p) = the k nearest points of R other than p itself, exact kNN):
 *
 *   Geometric consistency (paper Table 1: Hausdorff and mean distance)
 *     to_original   = statistics of d(r, O) over r in R
 *     to_resampled  = statistics of d(o, R) over o in O
 *     Hausdorff R->O = max_r d(r, O);   Hausdorff O->R = max_o d(o, R)
 *     Hausdorff      = max(Hausdorff R->O, Hausdorff O->R)   (symmetric)
 *     every distance is also reported divided by the diagonal of O's
 *     axis-aligned bounding box ("_rel").
 *
 *   Local density error (paper eq. 9, k = 6)
 *     dbar_i = mean_{q in NN_6(r_i)} |q - r_i|      (fewer neighbours when
 *              R has fewer than 7 points; points with none are left out)
 *     reported: range = max dbar - min dbar (the paper's d_local), mean,
 *     std (population) and cv = std / mean.
 *
 *   Voronoi density error (paper Table 2, "Voronoi")
 *     For each r_i: the PCA plane of r_i and NN_12(r_i) (13 points, as the
 *     authors' release does) gives the normal n_i and a tangent frame (u, v)
 *     through r_i; each neighbour q projects to ((q - r_i).u, (q - r_i).v);
 *     a_i = area of r_i's Voronoi cell among those 12 projections
 *     (core/voronoi.h: a square frame of half-width max |q_j| clipped by the
 *     bisectors). A cell that still touches the frame is open (r_i is on a
 *     boundary of the sampling) and is skipped; so is a point with fewer than
 *     3 neighbours. reported: closed cells, skipped points, range (max - min,
 *     the paper's measure), mean, std and cv = std / mean of the a_i.
 *
 *   Spacing
 *     d_min      = min_i |NN_1(r_i) - r_i|   (smallest pairwise distance)
 *     mean_nn    = mean_i |NN_1(r_i) - r_i|
 *     A          = (sum of closed a_i) * n / (number of closed cells):
 *                  the surface area, each skipped point assumed to own an
 *                  average cell.
 *     rho        = (d_min / 2) / sqrt(A / (2 sqrt(3) n))
 *                = d_min / sqrt(2 A / (sqrt(3) n))
 *                  the normalised Poisson-disk radius of Lagae and Dutre
 *                  (2008): disks of radius d_min / 2 against the radius of
 *                  n disks in a perfect hexagonal packing of area A (each
 *                  disk owns a hexagon of area 2 sqrt(3) r^2). A hexagonal
 *                  lattice of spacing s has A / n = (sqrt(3) / 2) s^2 and
 *                  d_min = s, so rho = 1; good blue-noise sets reach 0.75-0.9.
 *   Drift (how far resampled points left the scanned surface)
 *     drift_i    = d(r_i, O) / s(o_i), o_i the nearest original point and
 *                  s(o_i) the mean distance from o_i to its 6 nearest
 *                  original neighbours (the input's own local spacing);
 *                  reported: statistics of drift_i and the number of points
 *                  with drift_i > 1 (farther from the input than its spacing).
 *   A statistic over an empty set (e.g. local density of a 1-point cloud,
 *   rho with no closed cell) is NaN: text "n/a", JSON null.
 *
 * JSON (--json) writes one object; these names are the contract:
 *   original_points, resampled_points      point counts (finite points)
 *   bbox_diagonal                          diagonal of O's bounding box
 *   hausdorff_resampled_to_original        max_r d(r, O)
 *   hausdorff_original_to_resampled        max_o d(o, R)
 *   hausdorff                              the larger of the two
 *   mean_resampled_to_original             mean_r d(r, O)
 *   mean_original_to_resampled             mean_o d(o, R)
 *   <each of the five above>_rel           divided by bbox_diagonal
 *   local_density: {k, points, min, max, range, mean, std, cv}
 *   voronoi_area:  {k, closed, skipped, min, max, range, mean, std, cv}
 *   min_spacing                            d_min
 *   mean_nn_distance                       mean_nn
 *   surface_area                           A
 *   poisson_radius                         rho
 *   drift: {max, mean, over_local_spacing} drift_i statistics, count > 1
 *
 * Coordinates: the computation only ever uses differences of nearby points
 * (kNN, PCA relative to the query point, projections relative to r_i), so
 * georeferenced coordinates ~1e6 from 0 lose nothing; the command still
 * subtracts O's bounding-box minimum from both clouds after reading.
 */
#ifndef WPD_TOOLS_METRICS_H
#define WPD_TOOLS_METRICS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "common/error.h"
#include "common/warnings.h"

#define WPD_METRICS_K_LOCAL 6
#define WPD_METRICS_K_VORONOI 12

/* Summary of a set of values; all NaN when count is 0. std is the
 * population standard deviation; cv = std / mean. */
typedef struct wpd_metrics_stats {
    uint64_t count;
    double min, max, range, mean, std, cv;
} wpd_metrics_stats;

typedef struct wpd_metrics {
    uint64_t original_points, resampled_points;
    double bbox_diagonal;            /* of the original */
    wpd_metrics_stats to_original;   /* d(r, O) over r in R */
    wpd_metrics_stats to_resampled;  /* d(o, R) over o in O */
    double hausdorff;                /* max(to_original.max, to_resampled.max) */
    int k_local;                     /* WPD_METRICS_K_LOCAL */
    wpd_metrics_stats local;         /* dbar_i */
    int k_voronoi;                   /* WPD_METRICS_K_VORONOI */
    wpd_metrics_stats voronoi;       /* closed cell areas a_i; count = closed */
    uint64_t voronoi_skipped;        /* resampled_points - voronoi.count */
    wpd_metrics_stats nn;            /* |NN_1(r_i) - r_i|; min = d_min */
    double surface_area;             /* A */
    double poisson_radius;           /* rho */
    wpd_metrics_stats drift;         /* d(r, O) / local spacing of O near r */
    uint64_t drift_over;             /* resampled points with drift > 1 */
} wpd_metrics;

/* Computes every measure above for the original orig[3*i..3*i+2], i < n_orig,
 * and the resampled res[3*i..], i < n_res. Both arrays are read only.
 * threads <= 0 means the OpenMP default. The result does not depend on the
 * thread count. Returns 0, or -1 with err set: WPD_E_INPUT when a cloud is
 * empty or has more than 2^32 - 2 points, WPD_E_MEMORY. */
int wpd_metrics_compute(const double *orig, size_t n_orig, const double *res, size_t n_res,
                        int threads, wpd_metrics *m, wpd_error *err);

/* Reads the finite x y z of every point of a LAS or PLY file into a new
 * array (*xyz, free() it; 3 doubles per point). Returns 0, or -1 with err
 * set (WPD_E_INPUT for a file without finite points). */
int wpd_metrics_load(const char *path, double **xyz, size_t *n, wpd_error *err);

/* wpd_metrics_load for several files read as one cloud; warnings: NULL, or
 * room for npaths: each file's warnings (common/warnings.h) as its header
 * holds them, filled once the files are open (zeroed before). */
int wpd_metrics_load_many(const char *const *paths, int npaths, double **xyz, size_t *n,
                          wpd_warnings *warnings, wpd_error *err);

/* Writes m as one JSON object (field names above) and a newline. */
void wpd_metrics_write_json(FILE *f, const wpd_metrics *m);
/* Writes m as text, one metric per line, names left-aligned. */
void wpd_metrics_write_text(FILE *f, const wpd_metrics *m);

/* The subcommand: argv[0] = "metrics". Returns the exit status. */
int wpd_metrics_main(int argc, char **argv);

#endif
