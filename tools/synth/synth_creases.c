/* synth_creases.c - whether a surface point of `wpd synth`'s city lies on
 * a crease of a building (see synth_creases.h).
 *
 * Every crease of a box building projects onto the outline of its
 * footprint (wall tops, corners, feet) or onto its ridge line, so a point
 * farther than the band from both in plan is off every crease: most points
 * are settled by that test alone.
 */
#include "tools/synth/synth_creases.h"

#include <math.h>

#define DEG (180.0 / 3.14159265358979323846)

/* Squared distance from p to the segment a-b. */
static double segment_dist2(const double p[3], const double a[3], const double b[3])
{
    double ab[3], ap[3], len2 = 0, t = 0;
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k], ap[k] = p[k] - a[k];
        len2 += ab[k] * ab[k], t += ab[k] * ap[k];
    }
    t = len2 > 0 ? clampd(t / len2, 0, 1) : 0;
    double d2 = 0;
    for (int k = 0; k < 3; k++) {
        double d = ap[k] - t * ab[k];
        d2 += d * d;
    }
    return d2;
}

/* Plan distance from (x, y) to the outline of b's footprint. */
static double outline_dist(const building *b, double x, double y)
{
    double dx = max2(b->x0 - x, x - b->x1), dy = max2(b->y0 - y, y - b->y1);
    if (dx <= 0 && dy <= 0)
        return -max2(dx, dy);          /* inside: the nearest wall */
    return hypot(max2(dx, 0), max2(dy, 0));
}

/* Roof rise per metre, as a dihedral: two roof planes meet at the ridge
 * at 2 atan(slope); a roof plane meets the wall under its eave at
 * 90 - atan(slope). */
static double ridge_angle(const building *b) { return 2 * atan(b->slope) * DEG; }
static double eave_angle(const building *b) { return 90 - atan(b->slope) * DEG; }

/* Height of the foot of a wall at (x, y): the terrain, or the bottom of
 * the wall where the ground falls away below it. */
static double foot_z(const scene *sc, const building *b, double x, double y)
{
    return max2(terrain(sc, x, y), b->zb - 2.0);
}

/* The ridge: squared distance, or INFINITY for a flat roof or a gentle one. */
static double ridge_dist2(const building *b, const double p[3])
{
    if (b->roof == ROOF_FLAT || ridge_angle(b) < SYNTH_CREASE_MIN_DEGREES)
        return INFINITY;
    double xc = (b->x0 + b->x1) / 2, yc = (b->y0 + b->y1) / 2;
    double span = b->roof == ROOF_RIDGE_X ? b->y1 - b->y0 : b->x1 - b->x0;
    double zr = b->ze + b->slope * span / 2;
    double a[3] = {b->x0, yc, zr}, e[3] = {b->x1, yc, zr};
    if (b->roof == ROOF_RIDGE_Y)
        a[0] = e[0] = xc, a[1] = b->y0, e[1] = b->y1;
    return segment_dist2(p, a, e);
}

/* The top edge of one wall, from corner a to corner e (both at the eaves):
 * straight, or up to the ridge and down again on a gable wall. gable: the
 * wall is a gable end; its top meets the roof planes at 90 degrees, an
 * eave wall's at eave_angle. */
static double wall_top_dist2(const building *b, const double p[3], const double a[3],
                             const double e[3], int gable)
{
    if (!gable)
        return b->roof != ROOF_FLAT && eave_angle(b) < SYNTH_CREASE_MIN_DEGREES
                   ? INFINITY
                   : segment_dist2(p, a, e);
    double span = fabs(e[0] - a[0]) + fabs(e[1] - a[1]);
    double apex[3] = {(a[0] + e[0]) / 2, (a[1] + e[1]) / 2, b->ze + b->slope * span / 2};
    return fmin(segment_dist2(p, a, apex), segment_dist2(p, apex, e));
}

/* The nearest crease so far: its squared distance and kind. */
typedef struct nearest {
    double d2;
    int kind;
} nearest;

static void consider(nearest *n, double d2, int kind)
{
    if (d2 < n->d2)
        n->d2 = d2, n->kind = kind;
}

/* The wall tops, the corners and the feet. */
static void walls(const scene *sc, const building *b, const double p[3], nearest *n)
{
    const double cx[4] = {b->x0, b->x1, b->x1, b->x0}, cy[4] = {b->y0, b->y0, b->y1, b->y1};
    for (int i = 0; i < 4; i++) {
        int j = (i + 1) % 4;
        double a[3] = {cx[i], cy[i], b->ze}, e[3] = {cx[j], cy[j], b->ze};
        int along_x = cy[i] == cy[j];  /* walls 0 and 2 face south and north */
        int gable = (b->roof == ROOF_RIDGE_Y && along_x) || (b->roof == ROOF_RIDGE_X && !along_x);
        consider(n, wall_top_dist2(b, p, a, e, gable), CREASE_WALL_TOP);
        /* The corner, from its foot up to the eaves. */
        double foot[3] = {cx[i], cy[i], foot_z(sc, b, cx[i], cy[i])};
        consider(n, segment_dist2(p, foot, a), CREASE_CORNER);
        /* The foot of the wall: its point nearest to p in plan, at the
         * terrain's height there (the terrain bends too gently for the
         * difference to matter within the band). */
        double q[3] = {along_x ? clampd(p[0], b->x0, b->x1) : cx[i],
                       along_x ? cy[i] : clampd(p[1], b->y0, b->y1), 0};
        q[2] = foot_z(sc, b, q[0], q[1]);
        consider(n, segment_dist2(p, q, q), CREASE_FOOT);
    }
}

int synth_on_crease(const scene *sc, const building *b, double x, double y, double z,
                    double band)
{
    double p[3] = {x, y, z};
    double near_ridge = b->roof == ROOF_RIDGE_X ? fabs(y - (b->y0 + b->y1) / 2)
                        : b->roof == ROOF_RIDGE_Y ? fabs(x - (b->x0 + b->x1) / 2)
                                                  : INFINITY;
    if (outline_dist(b, x, y) > band && near_ridge > band)
        return CREASE_NONE;
    nearest n = {ridge_dist2(b, p), CREASE_RIDGE};
    walls(sc, b, p, &n);
    return n.d2 <= band * band ? n.kind : CREASE_NONE;
}
