/* sharp.h - the sharp-feature (edge) detector on the input points.
 *
 * The paper takes edge labels from MSL-Net, a trained network; this is a
 * geometric stand-in. A point is a sharp-feature point when it lies on a
 * crease of the surface around it: two planar faces meeting at 30 degrees
 * or more, the point within 0.55 local point spacings of the line
 * where they meet (crease.h has the test and the reasons), and another
 * point within WPD_SHARP_SUPPORT spacings on a crease by that test too
 * (the support: a crease is a line). Its
 * neighbourhood: the points nearest to it closer than the cap, of which
 * the WPD_SHARP_SPACING_K-th gives the local spacing (a disc of that
 * radius holds that many points), and the test takes those within
 * WPD_SHARP_REACH spacings (at most WPD_KNN_MAX). Why a reach in spacings:
 * the label does not depend on the cap (the run's radius estimate) once
 * the cap is wider than the reach, so a point gets the same label from any
 * target count that leaves the cap that wide; narrower caps see fewer
 * points and find fewer creases.
 *
 * Bounded neighbourhoods, so that a block labels its points exactly:
 * equal distances are ordered by coordinates (x, then y, then z), never by
 * index, and the points enter the test in that order, so the test's
 * verdict on p is a function of p and of the coordinates of the grid
 * points closer than cap to it, and p's label one of the grid points
 * closer than WPD_SHARP_DEPTH x cap (the support lies within a cap). A
 * block whose grid holds every input point that close to p labels p as
 * the whole cloud does (in the same coordinate frame), whatever the order
 * of its points or the threads. For a tile whose grid holds its own points
 * and the halo points within H of its box, that is every own point when
 * 2 cap <= H, and every halo point closer than H - 2 cap to the box.
 */
#ifndef WPD_SHARP_H
#define WPD_SHARP_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"
#include "method/crease.h"

/* The neighbour (not counting the point) whose distance gives the spacing. */
#define WPD_SHARP_SPACING_K 12
/* Radius of the crease test, in local spacings. */
#define WPD_SHARP_REACH 5.0
/* A point the crease test puts on a crease is labelled sharp when another
 * point (not at its place) closer than this many of its spacings, and
 * than the cap, is on a crease by the test too: a crease is a line, and a
 * verdict with no other along it is noise (sharp.c says what it measured). */
#define WPD_SHARP_SUPPORT 3.0
/* How far a label looks, in caps: its support's neighbourhoods reach one
 * cap beyond the support radius, itself at most a cap. */
#define WPD_SHARP_DEPTH 2.0
/* The verdict (wpd_sharp_verdicts) of a point on a crease without support. */
#define WPD_SHARP_ALONE WPD_CREASE_VERDICTS

/* Labels the grid's source points begin..end-1 (end <= surface->n; a
 * tile's own points first, halo points after them): writes edge[i] = 1
 * (sharp) or 0 for i in [begin, end), edge indexed by source index; every
 * grid point serves as a neighbour. cap > 0 (INFINITY: no cap). */
void wpd_detect_sharp_capped(const wpd_grid *surface, size_t begin, size_t end, double cap,
                             uint8_t *edge, int threads);

/* Labels on demand, for the Poisson pass (method/poisson.h, wpd_labeller):
 * the label of source point i of the grid (coordinates xyz[3 i ..], the
 * array the grid was built from), the one wpd_detect_sharp_capped gives,
 * computed when asked and kept in edge[i]. The crease test's verdicts are
 * kept too (a byte a source index), for the support of the points around.
 * `callers`: how many threads may ask at once (1: one at a time, from any
 * thread; more: OpenMP threads 0 .. callers - 1). NULL out of memory. */
typedef struct wpd_sharp_labeller wpd_sharp_labeller;
wpd_sharp_labeller *wpd_sharp_labeller_new(const wpd_grid *surface, const double *xyz, double cap,
                                           uint8_t *edge, int callers);
/* A wpd_labeller: ctx is a wpd_sharp_labeller. */
int wpd_sharp_label(void *ctx, uint32_t point);
/* Labels computed so far. */
uint64_t wpd_sharp_labeller_count(const wpd_sharp_labeller *l);
void wpd_sharp_labeller_free(wpd_sharp_labeller *l);

/* For measurements: the crease test's verdict (wpd_crease_verdict) on
 * every grid point, verdict indexed by source index. */
void wpd_sharp_verdicts(const wpd_grid *surface, double cap, uint8_t *verdict, int threads);

#endif
