/* smooth_surface.h - keeping smoothed samples on the input surface
 * (internal to method/smooth.c).
 *
 * The guarantee: no sample ends farther from the input than the input's
 * own local spacing there (the mean distance from its nearest input point
 * to that point's 6 nearest neighbours, the definition `wpd metrics`
 * reports drift against). Positions are judged as the output will store
 * them: on its lattice (multiples of the LAS scale in the block frame,
 * which starts at an input point), or as they are where the output has no
 * lattice (res 0).
 */
#ifndef WPD_SMOOTH_SURFACE_H
#define WPD_SMOOTH_SURFACE_H

#include "core/grid.h"

/* p rounded to the output's lattice (multiples of res per axis); unchanged
 * on the axes where res is 0. out may be p. */
void wpd_round_to_output(const double res[3], const double p[3], double out[3]);

/* 1 if stored, p rounded by wpd_round_to_output, lies within a thousandth
 * of the lattice step of p on every axis: p is that lattice point but for
 * the floating error of its coordinates (always 1 where res is 0). */
int wpd_on_lattice(const double res[3], const double p[3], const double stored[3]);

/* 1 if a sample starting at the input point `start` is on no scanned
 * surface at the sampling's scale (radius spacing): the mean distance from
 * start to its 6 nearest other input points is above 1.5 spacing. */
int wpd_off_surface(const wpd_grid *surface, const double start[3], double spacing);

/* What one query of the input points nearest to a point `at` says about
 * the points near it: the distance d0 from `at` to its nearest input point
 * and the mean m6 of its distances to its 6 nearest (d0 among them). For
 * an input point x, spacing(x) >= m6 - |at x| (x's 6 neighbours are 6
 * points other than x, each no nearer to `at` than the matching one of
 * the six nearest, and |x y| >= |at y| - |at x|). So a position s at
 * distance e from `at`, whose nearest input point x lies within e + d0 of
 * it and so within 2 e + d0 of `at`, is within the local spacing of the
 * input when 2 d0 + 3 e <= m6: wpd_hold_on_surface then needs no query.
 * One per sample, kept across its moves; `valid` 0 until a query fills
 * it. */
typedef struct wpd_surface_memo {
    double at[3];
    double d0, m6;
    int valid;
} wpd_surface_memo;

/* Refills memo from a query at `at` that found the got input points nearest
 * to it, at squared distances d2 (ascending): any query of 6 or more fills
 * it (projecting a sample onto the surface asks for 13), fewer leave it as
 * it was. */
void wpd_surface_memo_fill(wpd_surface_memo *memo, const double at[3], const double *d2,
                           int got);

/* Moves p, rounded to the output's lattice, until it is within the input's
 * local spacing of its nearest input point (pulled straight towards that
 * point; after a few rounds onto the point itself). memo (may be NULL):
 * the sample's last query, read to skip a query it settles and refilled
 * by every query made; the result does not depend on it. Returns 1 if p
 * was pulled, 0 if rounding alone kept it. */
int wpd_hold_on_surface(const wpd_grid *surface, const double res[3], wpd_surface_memo *memo,
                        double p[3]);

#endif
