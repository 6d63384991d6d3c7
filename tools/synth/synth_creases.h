/* synth_creases.h - the ground truth of sharp features in `wpd synth`'s
 * city: whether a surface point lies on a crease of a building.
 *
 * A crease is a line where two surfaces of the scene meet at a dihedral
 * angle (the angle between their normals) of at least
 * SYNTH_CREASE_MIN_DEGREES: the roof ridge (2 atan(slope), 48-80 degrees),
 * the top edges of the four walls (eaves and gable tops, where roof and
 * wall meet: 90 degrees, or 90 - atan(slope) >= 49 degrees under a sloped
 * roof), the four vertical wall corners (90) and the wall feet, where each
 * wall meets the terrain (90, give or take the terrain's slope of a few
 * percent). A point is on a crease when it lies within a band of half the
 * point spacing of one, measured in 3D from its noiseless position (before
 * the ranging noise and the 0.01 m grid). The point spacing: the survey's
 * pulse spacing, the distance between neighbouring pulses on the ground
 * along and across track in one strip (flight.line_spacing, 0.35 to 0.38
 * m; the 12 points/m2 of the scene count the strips' overlaps and the
 * multiple returns of the trees too); for the oblique survey, whose
 * strips all overlap, the spacing of the pulses of all strips together
 * (flight.point_spacing, 0.32 m). The creases are the scene's geometry,
 * whether or not the scanner sees both sides: in the default survey the
 * walls facing north and south are parallel to every pulse (the mirror
 * sweeps across track only) and get no points, so their creases show in
 * the cloud as the border of a roof or of the ground beside the building.
 * Vegetation and noise are never on a crease; the terrain alone has none
 * (its slopes change by a few percent). The kind of the nearest crease
 * within the band is kept (enum synth_crease), so that a measurement can
 * tell the creases whose two faces carry points (ridges) from the others.
 * Implemented by synth_creases.c.
 */
#ifndef WPD_SYNTH_CREASES_H
#define WPD_SYNTH_CREASES_H

#include "tools/synth/synth_scene.h"

#define SYNTH_CREASE_MIN_DEGREES 30.0

/* Kinds of crease, as written in the edge_truth field (0: none). */
enum synth_crease {
    CREASE_NONE = 0,
    CREASE_RIDGE = 1,     /* two roof planes */
    CREASE_WALL_TOP = 2,  /* roof and wall: eaves, gable tops, flat roof edges */
    CREASE_CORNER = 3,    /* two walls */
    CREASE_FOOT = 4,      /* wall and terrain */
};

/* The kind of the crease of building b nearest to the surface point
 * (x, y, z) (local metres) of a roof, a wall or the ground of b's lot when
 * it lies within band (half the point spacing), else CREASE_NONE. */
int synth_on_crease(const scene *sc, const building *b, double x, double y, double z,
                    double band);

#endif
