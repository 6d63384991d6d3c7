/* crease.h - whether a point lies on a crease of the surface its
 * neighbourhood samples: the geometric test behind the sharp-feature
 * detector (sharp.h), on one neighbourhood at a time.
 *
 * A crease is where two planar faces meet at a dihedral angle of at least
 * WPD_CREASE_MIN_DEGREES. The neighbourhood is split into two faces (by
 * the side of its middle principal axis, then points moved to the nearer
 * plane until the split is stable), and it is a crease when
 *   - each face holds WPD_CREASE_MIN_FACE points or more and is planar: the
 *     RMS distance to its plane is at most WPD_CREASE_FLATNESS x the
 *     spacing, and at most a tenth of its points lie farther than three
 *     times that (vegetation, multiple returns and noise fail here: their
 *     neighbourhoods are not two planes);
 *   - the normals are WPD_CREASE_MIN_DEGREES or more apart;
 *   - each steep face (normal more than 45 degrees from z) is a plane its
 *     own points determine: WPD_CREASE_MIN_OWN or more of them lie off
 *     the other face's plane (beyond twice the flatness tolerance), not
 *     all on one line: one lies WPD_CREASE_ROW_WIDTH spacings or more off
 *     it (a single row of wall points and the other face's row nearest
 *     the crease make a plane that is no surface: its line with the other
 *     face runs through that row);
 *   - the faces lie on either side of the line where their planes meet
 *     (a fold, not two planes crossing), each within its plane: at most a
 *     tenth of a face's points lie beyond the line by more than three
 *     times the flatness.
 * The point is on the crease when it is within WPD_CREASE_BAND spacings of
 * that line: a little wider than the band of the ground truth of `wpd
 * synth --edge-truth` (half the point spacing), because the line is fitted
 * to noisy points and its error puts truth points just outside a band of
 * exactly the truth's width. Where a face is steep the spacing is at most that of the
 * denser face (a wall's sparse rows inflate the nearest neighbours'). A
 * neighbourhood that is one plane (surface variation below
 * WPD_CREASE_MIN_VARIATION) is no crease, whatever its border: a crease one
 * of whose faces carries no points cannot be located from the points.
 * Where two faces do not describe the neighbourhood (the two-face split is
 * not planar, or the surface variation exceeds WPD_CREASE_MAX_VARIATION: a
 * ball around a point of a two-face crease has at most 0.09 when the
 * normals are 90 degrees apart, 0.14 at 120), three are tried: a corner,
 * where two walls meet a roof or the ground. The rougher of the two faces
 * is split again, the three planes refined, and when all three hold
 * WPD_CREASE_MIN_FACE points or more and are planar, the point is on a
 * crease when it is on that of any two of them by the rules above (on
 * their points alone). Above WPD_CREASE_MAX_VARIATION3 the neighbourhood
 * is a volume (a crown, a cluster of returns), rejected before any split;
 * between the two bounds it is one too when both starts of the two-face
 * split leave both sides far from any plane at their first fit (a corner
 * split leaves one side near a plane: a wall, or the roof).
 */
#ifndef WPD_CREASE_H
#define WPD_CREASE_H

#define WPD_CREASE_MIN_DEGREES 30.0
/* Its cosine (a literal: cos() in the test costs a few percent; the unit
 * tests check that the two agree). */
#define WPD_CREASE_COS_MIN 0.86602540378443865
#define WPD_CREASE_MIN_FACE 5
/* Half-width of the band around the fitted line, in spacings. The truth's is
 * 0.5; the fitted line's error puts truth points just outside a band of
 * exactly that width. Chosen with the support rule (sharp.h) on the oblique
 * survey (300 K, seeds 1-10, cap of a 1 % run) for the labels `resample
 * --sharp` writes: there a crease counts by its length (the pass keeps one
 * sample every r/2 along it), and where a scan row runs beside a ridge
 * outside the truth's band its labelled points are the only ones the pass
 * can keep, so a wide band costs precision. Precision / recall of the
 * resampled labels (bench/sharp_labels.py): 0.57 gives 0.79-0.88 / 0.93-0.97
 * (7 of 10 seeds with both >= 0.8), 0.55 0.81-0.89 / 0.93-0.97 (10), 0.53
 * 0.82-0.91 / 0.93-0.97 (10); over every input point (`wpd edges`) 0.57
 * gives 0.81-0.87 / 0.78-0.89 (9 of 10), 0.55 0.84-0.89 / 0.77-0.88 (8: seed
 * 4's recall 0.796, seed 9's 0.768). docs/algorithm.md section 5. */
#define WPD_CREASE_BAND 0.55
#define WPD_CREASE_FLATNESS 0.15
#define WPD_CREASE_MIN_VARIATION 0.004
#define WPD_CREASE_MAX_VARIATION 0.15
/* Isotropic points have 1/3: a corner of three perpendicular faces comes close. */
#define WPD_CREASE_MAX_VARIATION3 0.34
/* A steep face (|normal z| below WPD_CREASE_STEEP_COS, cos 45 degrees)
 * needs WPD_CREASE_MIN_OWN own points (farther than WPD_CREASE_OWN_TOL
 * flatness tolerances from the other face's plane), one of them
 * WPD_CREASE_ROW_WIDTH spacings off the line through them (the columns
 * of two strips on a wall can lie a third of a spacing apart, and are two
 * rows): crease.c. */
#define WPD_CREASE_STEEP_COS 0.70710678118654752
#define WPD_CREASE_MIN_OWN 3
#define WPD_CREASE_OWN_TOL 2.0
#define WPD_CREASE_ROW_WIDTH 0.3

/* Why a neighbourhood is or is not a crease (for measurements). */
typedef enum wpd_crease_verdict {
    WPD_CREASE_ON = 0,     /* on the crease: within the band of its line */
    WPD_CREASE_NEAR,       /* a crease, the point farther than the band */
    WPD_CREASE_FLAT,       /* one plane */
    WPD_CREASE_SMALL_FACE, /* a face with too few points */
    WPD_CREASE_ROUGH,      /* a face not planar: neither two nor three planes */
    WPD_CREASE_SHALLOW,    /* faces less than the minimum angle apart */
    WPD_CREASE_CROSSING,   /* faces not on either side of their line */
    WPD_CREASE_ROW,        /* a steep face whose own points are one row: its
                              plane is not determined */
    WPD_CREASE_VERDICTS
} wpd_crease_verdict;

/* The verdict on point p (one of the m points pts[3 m], the neighbourhood,
 * in a fixed order: the result depends on it only through rounding) for a
 * local point spacing `spacing` (> 0). m <= 64 (more are ignored). */
wpd_crease_verdict wpd_crease_test(const double *pts, int m, const double p[3], double spacing);

#endif
