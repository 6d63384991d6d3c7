/* synth_trace.c - one pulse of `wpd synth`'s scanner through the scene
 * (see synth_trace.h): ray against terrain, roofs and walls, then tree
 * crowns above the surface found, and the rare noise return.
 *
 * Walls get points because the pulses are tilted rays: one leaning towards
 * a facade meets the facade, so roof edges stay sharp and walls shade the
 * ground behind them.
 */
#include "tools/synth/synth_trace.h"

#include "tools/synth/synth_creases.h"

#include <math.h>
#include <string.h>

#define CROWN_PROBE 8.0         /* height above ground where rays look for crowns */
#define NOISE_RATE (1.0 / 7000.0)

/* x where ray r is at height z. */
static inline double ray_x(const ray *r, double z) { return r->xa + (r->za - z) * r->s; }

/* A surface point found by a ray is an echo (synth_trace.h) until the
 * crowns above it are known: it may become the last return or none. */
typedef echo hit;

/* Highest point where the ray meets the roof of b; 0 if it misses the roof. */
static int roof_hit(const building *b, const ray *r, hit *h)
{
    if (b->roof != ROOF_RIDGE_Y) {
        double z = b->ze;
        if (b->roof == ROOF_RIDGE_X)
            z += b->slope * ((b->y1 - b->y0) / 2 - fabs(r->y - (b->y0 + b->y1) / 2));
        double x = ray_x(r, z);
        if (x < b->x0 || x > b->x1)
            return 0;
        h->x = x, h->z = z;
        return 1;
    }
    /* Ridge along y: two planes rising from the eaves at x0 and x1. */
    double k = b->slope, cx = (b->x0 + b->x1) / 2, best = -INFINITY;
    double zw = (b->ze + k * (r->xa + r->za * r->s - b->x0)) / (1 + k * r->s);
    double xw = ray_x(r, zw);
    if (xw >= b->x0 && xw <= cx)
        best = zw, h->x = xw;
    double ze = (b->ze + k * (b->x1 - r->xa - r->za * r->s)) / (1 - k * r->s);
    double xe = ray_x(r, ze);
    if (xe >= cx && xe <= b->x1 && ze > best)
        best = ze, h->x = xe;
    if (best == -INFINITY)
        return 0;
    h->z = best;
    return 1;
}

/* First point where the ray meets building b (roof or wall); 0 if none. */
static int building_hit(const building *b, const ray *r, hit *h)
{
    if (r->y < b->y0 || r->y > b->y1)
        return 0;
    h->shade = b->shade;
    if (roof_hit(b, r, h)) {
        h->material = MAT_ROOF;
        return 1;
    }
    /* Wall top: the eaves, or the gable profile on the end walls. */
    double top = b->ze;
    if (b->roof == ROOF_RIDGE_X)
        top += b->slope * ((b->y1 - b->y0) / 2 - fabs(r->y - (b->y0 + b->y1) / 2));
    double xt = ray_x(r, top), wall;
    if (r->s > 0 && xt < b->x0)
        wall = b->x0;
    else if (r->s < 0 && xt > b->x1)
        wall = b->x1;
    else
        return 0;
    double z = r->za - (wall - r->xa) / r->s;
    /* The wall reaches below the base (set at the centre's ground) where the
     * ground falls away; the caller keeps the hit only above the ground. */
    if (z < b->zb - 2.0 || z > top)
        return 0;
    h->x = wall, h->z = z, h->material = MAT_WALL;
    return 1;
}

/* The scene's (x, y) of the point (u, v) of the ray's frame. */
static inline void scene_xy(const tracer *tr, double u, double v, double *x, double *y)
{
    if (tr->transposed)
        *x = v, *y = u;
    else
        *x = u, *y = v;
}

/* Vertical extent of the crown along the ray (treated as vertical inside
 * the crown); 0 if the ray misses it. */
static int crown_chord(const tracer *tr, const tree *t, const ray *r, double *top,
                       double *bottom)
{
    double x, y;
    scene_xy(tr, ray_x(r, t->zc), r->y, &x, &y);
    double dx = x - t->cx, dy = y - t->cy;
    double d2 = dx * dx + dy * dy, reach = t->rh * (1 + t->lobe);
    if (d2 >= reach * reach)
        return 0;
    double c = 1;
    if (d2 > 1e-12) {
        c = (dx * t->rot_c + dy * t->rot_s) / sqrt(d2);
    }
    double radius = t->rh * (1 + t->lobe * (4 * c * c * c - 3 * c));   /* cos 3 phi */
    double q = d2 / (radius * radius);
    if (q >= 1)
        return 0;
    double half = t->rv * sqrt(1 - q);
    *top = t->zc + half, *bottom = t->zc - half;
    return 1;
}

/* 1 if (x, y) lies on the cached lot, at least `margin` inside it. */
static inline int inside_lot(const building *b, double x, double y, double margin)
{
    return b->valid && x >= b->lx0 + margin && x < b->lx1 - margin && y >= b->ly0 + margin &&
           y < b->ly1 - margin;
}

/* Building b in the ray's frame: b itself, or in a transposed tracer a
 * copy with x and y swapped. */
static const building *in_frame(const tracer *tr, const building *b, building *copy)
{
    if (!tr->transposed)
        return b;
    *copy = *b;
    copy->x0 = b->y0, copy->x1 = b->y1, copy->y0 = b->x0, copy->y1 = b->x1;
    copy->lx0 = b->ly0, copy->lx1 = b->ly1, copy->ly0 = b->lx0, copy->ly1 = b->lx1;
    copy->roof = b->roof == ROOF_RIDGE_X ? ROOF_RIDGE_Y
                 : b->roof == ROOF_RIDGE_Y ? ROOF_RIDGE_X
                                           : b->roof;
    return copy;
}

/* The building on the lot at (u, v) of the ray's frame, through lookup
 * cache k; NULL on a street or in a park. */
static const building *building_under(tracer *tr, double u, double v, int k, int *street)
{
    double x, y;
    scene_xy(tr, u, v, &x, &y);
    return synth_building_at(tr->sc, x, y, &tr->blocks[k], &tr->lots[k], street);
}

/* Horizontal run of a steep ray between the looks for buildings it may
 * pass over (lots and streets are wider). */
#define PROBE_RUN 10.0

/* The first surface the ray meets below the tree tops: ground or building. */
static hit trace_solid(tracer *tr, const ray *r)
{
    const scene *sc = tr->sc;
    /* Where the ray meets the terrain: one step from the previous pulse's
     * height (neighbouring pulses differ by centimetres); the point is on
     * the terrain, off the ray by far less than the ranging noise. */
    double x = ray_x(r, tr->ground_guess), gx, gy;
    scene_xy(tr, x, r->y, &gx, &gy);
    double z = terrain(sc, gx, gy);
    tr->ground_guess = z;
    int street, street_top;
    hit best = {x, z, MAT_GROUND, 1.0, 0}, h;
    building view, between;
    const building *b = building_under(tr, x, r->y, 0, &street);
    const building *on = b;      /* the ground of b's lot, or the building hit */
    if (street)
        best.material = MAT_STREET;
    if (b && building_hit(in_frame(tr, b, &view), r, &h) && h.z > best.z)
        best = h;
    const building *b2 = building_under(tr, ray_x(r, z + sc->tallest), r->y, 1, &street_top);
    if (b2 && !(b && b2->bi == b->bi && b2->bj == b->bj && b2->li == b->li && b2->lj == b->lj) &&
        building_hit(in_frame(tr, b2, &view), r, &h) && h.z > best.z)
        best = h, on = b2;
    /* A steep ray may pass over a lot between the two: look every
     * PROBE_RUN metres of its run. */
    int looks = tr->steep ? (int)ceil(sc->tallest * fabs(r->s) / PROBE_RUN) : 1;
    for (int k = 1; k < looks; k++) {
        int st;
        const building *bk =
            building_under(tr, ray_x(r, z + sc->tallest * k / looks), r->y, 2, &st);
        if (bk && building_hit(in_frame(tr, bk, &view), r, &h) && h.z > best.z)
            best = h, between = *bk, on = &between;
    }
    /* The ground near a foot lies on the lot of its building (lots keep
     * 3 m around a building), so b is the one building it can be near. */
    best.crease = 0;
    if (tr->crease_band > 0 && on) {
        double cx, cy;
        scene_xy(tr, best.x, r->y, &cx, &cy);
        best.crease = synth_on_crease(sc, on, cx, cy, best.z, tr->crease_band);
    }
    return best;
}

/* Returns of a ray through a crown spanning [bottom, top] above `solid`. */
static int crown_echoes(rng *g, const ray *r, const hit *solid, double top, double bottom,
                        echo out[MAX_RETURNS])
{
    static const double cumulative[MAX_RETURNS] = {0.12, 0.45, 0.80, 0.95, 1.0};
    double u = rng_unit(g);
    int n = 1;
    while (n < MAX_RETURNS && u >= cumulative[n - 1])
        n++;
    int last_on_solid = n > 1 && rng_unit(g) < 0.7;
    double u2 = rng_unit(g);     /* first-return depth: mostly shallow */
    double first = top - min2(0.8 * u2 * u2, (top - bottom) * 0.5);
    double low = max2(bottom, solid->z + 0.5);
    if (low > first)             /* a crown barely above the surface */
        low = first;
    int in_crown = n - last_on_solid;
    /* Returns after the first are spread over equal slices of the chord. */
    for (int i = 0; i < in_crown; i++) {
        double z = first;
        if (i > 0) {
            double slice = (first - low) / (in_crown - 1 + 1e-9);
            z = first - slice * (i - 1 + rng_unit(g));
            if (z < low) z = low;
        }
        out[i] = (echo){ray_x(r, z), z, MAT_TREE, 1.0, 0};
    }
    if (last_on_solid)
        out[n - 1] = *solid;
    return n;
}

/* Traces one pulse: the number of echoes (1..MAX_RETURNS) written to out. */
static int trace_echoes(tracer *tr, rng *g, const ray *r, echo out[MAX_RETURNS])
{
    const scene *sc = tr->sc;
    hit solid = trace_solid(tr, r);
    if (rng_unit(g) < NOISE_RATE) {
        double z = rng_unit(g) < 0.6 ? solid.z + 15 + 100 * rng_unit(g)
                                     : solid.z - 0.5 - 5 * rng_unit(g);
        out[0] = (echo){ray_x(r, z), z, MAT_NOISE, 1.0, 0};
        return 1;
    }
    /* Built lots hold no trees: only street crowns reach a little way in. */
    double px, py;
    scene_xy(tr, ray_x(r, solid.z + CROWN_PROBE), r->y, &px, &py);
    const tree *t = NULL;
    if (!inside_lot(&tr->lots[0], px, py, TREE_MAX_REACH - KERB_OFFSET))
        t = synth_tree_at(sc, px, py, &tr->blocks[3], tr->trees);
    double top, bottom;
    if (t && crown_chord(tr, t, r, &top, &bottom) && top > solid.z + 0.5)
        return crown_echoes(g, r, &solid, top, bottom, out);
    out[0] = solid;
    return 1;
}

void synth_tracer_orient(tracer *tr, int transposed, int steep)
{
    tr->transposed = transposed;
    tr->steep = steep;
}

void synth_tracer_init(tracer *tr, const scene *sc, double crease_band)
{
    memset(tr, 0, sizeof *tr);
    tr->sc = sc;
    tr->crease_band = crease_band;
    tr->ground_guess = GROUND_LEVEL;
}

/* Traces one pulse; returns the number of echoes, or 0 when one of them
 * falls outside the scene square (the whole pulse is then not recorded, so
 * the bounds are the scene's and every recorded pulse is complete). */
int synth_trace_pulse(tracer *tr, rng *g, const ray *r, echo out[MAX_RETURNS])
{
    int n = trace_echoes(tr, g, r, out);
    for (int i = 0; i < n; i++)
        if (out[i].x < 0 || out[i].x > tr->sc->side)
            return 0;
    return n;
}
