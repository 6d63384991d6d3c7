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

/* Moves p, rounded to the output's lattice, until it is within the input's
 * local spacing of its nearest input point (pulled straight towards that
 * point; after a few rounds onto the point itself). Returns 1 if p was
 * pulled, 0 if rounding alone kept it. */
int wpd_hold_on_surface(const wpd_grid *surface, const double res[3], double p[3]);

#endif
