/* synth.c - a synthetic city-like airborne LiDAR scan (see synth.h).
 *
 * THE SCENE (local metres; x east, y north; the square [0, L] x [0, L] is
 * written at the georeferenced origin 500000 E, 4500000 N)
 *  - L = sqrt(N / 12): about 12 points per m2 whatever N (at least 10 m).
 *  - Terrain: rolling ground, the sum of four plane waves of 2500 .. 110 m
 *    wavelength around 120 m elevation (slopes of a few percent); class 2.
 *    Streets (darker, low intensity) and yards/parks (brown) are both ground.
 *  - Blocks: a 96 m grid of 80 m blocks and 16 m streets, centred on the
 *    scene. 15 % of the blocks are parks (never the central one), the others
 *    are split into 1..3 x 1..3 lots, each with one box building: hashed
 *    footprint (>= 3 m setback), 1..20 floors (mostly low; at most a quarter
 *    of the flying height), a flat roof or, for buildings of up to 3 floors
 *    and 20 m span, a gabled roof whose ridge runs along the longer side.
 *    Roofs and walls are class 6. Walls get points because the pulses are
 *    traced as tilted rays: a ray leaning towards a facade meets the facade;
 *    roof edges stay sharp and walls shade the ground behind them.
 *  - Trees: along both kerbs of every street (10 m slots, 75 % planted) and
 *    on a 10 m jittered grid in parks (65 %). A crown is an ellipsoid with a
 *    three-lobed, rotated outline; a pulse through it gives 1..5 returns: the
 *    first near the crown top, the next ones deeper in the crown, the last
 *    often on what lies below (ground or building); class 5.
 *  - Noise: one pulse in ~7000 returns a single outlier, 15..115 m above
 *    (birds, haze) or up to 5.5 m below the surface (multipath); class 7.
 *
 * THE ACQUISITION
 *  - Parallel north/south strips, alternating direction, swath W = L / 2.4
 *    clamped to 60..500 m, strip spacing 0.7 W (30 % side overlap, so the
 *    overlaps have double density); at least 3 strips, centred on the scene;
 *    each strip is its own point_source_id. Flying height W / 2 / tan 22 deg
 *    (74 .. 619 m: small scenes are low, UAV-like surveys).
 *  - An oscillating mirror sweeps -22..+22 deg across track at equal angular
 *    steps (zig-zag: alternate lines run in opposite directions), so ground
 *    spacing widens towards the swath edges; the ground speed wobbles by 8 %
 *    along track. Pulses landing outside the scene square are not recorded.
 *  - Exact N: before each scan line the along-track line spacing is set from
 *    the points still needed, the scan length still to fly and the returns
 *    per pulse observed so far (aiming a few lines past the need), and the
 *    output stops at the N-th point, mid-pulse if so. Should the planned
 *    flight end short (only possible for tiny N), the strips are flown again
 *    with new source ids.
 *  - gps_time (adjusted standard GPS time) increases pulse by pulse; the
 *    returns of one pulse share it. Intensity and colour depend on the
 *    surface, the scan angle and the return number, with noise.
 *
 * Randomness: scene features come from a stateless hash of (seed, cell), the
 * scan from one splitmix64 stream seeded from the seed, consumed in
 * a fixed order: no dependence on anything but (N, seed).
 * Coordinates are rounded to the 0.01 m LAS grid before they are stored or
 * assigned to a tile, so LAS and PLY hold the same values and the tiles'
 * bounds cannot overlap.
 */
#include "synth.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/batch.h"
#include "io/writer.h"

/* ------------------------------------------------------------ parameters */

#define DENSITY 12.0            /* points per m2 over the scene */
#define MIN_SIDE 10.0           /* smallest scene edge, metres */
#define ORIGIN_X 500000.0       /* georeferenced position of local (0, 0) */
#define ORIGIN_Y 4500000.0
#define COORD_SCALE 0.01        /* LAS scale; every coordinate is rounded to it */
#define GROUND_LEVEL 120.0      /* mean terrain elevation */

#define BLOCK_PERIOD 96.0       /* street + block */
#define STREET_WIDTH 16.0
#define PARK_SHARE 0.15
#define LOT_SETBACK 3.0
#define FLOOR_HEIGHT 3.1
#define MAX_FLOORS 20
#define GABLE_MAX_SPAN 20.0     /* widest building with a gabled roof */
#define MAX_GABLE_SLOPE 0.85    /* rise per metre */
#define MAX_HEIGHT_SHARE 0.25   /* tallest building / flying height: < the side
                                   overlap, so strips still overlap at roof level */

#define KERB_OFFSET 2.5         /* street tree line distance from the block edge */
#define TREE_SLOT 10.0          /* street tree spacing, park tree grid */
#define TREE_MAX_REACH 4.6      /* largest crown radius incl. lobes */
#define CROWN_PROBE 8.0         /* height above ground where rays look for crowns */

#define SCAN_HALF_ANGLE (22.0 * 3.14159265358979323846 / 180.0)
#define SWATH_MIN 60.0          /* small scenes are low (UAV-like) surveys */
#define SWATH_MAX 500.0
#define SIDE_OVERLAP 0.30
#define MIN_STRIPS 3
#define GROUND_SPEED 60.0       /* m/s, nominal, for the widest swath */
#define MIN_GROUND_SPEED 8.0
#define TURN_TIME 90.0          /* s between strips */
#define GPS_START 335000000.0   /* adjusted standard GPS time of the first pulse */
#define RETURNS_PRIOR 1.2       /* expected points per pulse before measuring */
#define NOISE_RATE (1.0 / 7000.0)

#define BATCH_POINTS 65536      /* points per write, one file */
#define BATCH_BUDGET (1 << 20)  /* points buffered over all tiles */
#define MAX_RETURNS 5

enum material { MAT_GROUND, MAT_STREET, MAT_ROOF, MAT_WALL, MAT_TREE, MAT_NOISE, MAT_COUNT };

static const uint8_t material_class[MAT_COUNT] = {2, 2, 6, 6, 5, 7};
static const double material_intensity[MAT_COUNT] = {21000, 9000, 27000, 15000, 17000, 5000};
static const uint8_t material_rgb[MAT_COUNT][3] = {
    {128, 100, 70}, {78, 76, 74}, {140, 140, 142}, {165, 155, 140}, {62, 112, 52}, {200, 200, 200},
};

/* ------------------------------------------------------------ randomness */

static inline uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Stateless hash of a scene feature: (seed, kind of feature, cell a b c). */
static inline uint64_t feature_hash(uint64_t seed, uint64_t kind, int64_t a, int64_t b, int64_t c)
{
    uint64_t h = mix64(seed ^ (kind * 0x9e3779b97f4a7c15ULL));
    h = mix64(h ^ (uint64_t)a);
    h = mix64(h ^ ((uint64_t)b * 0xd6e8feb86659fd93ULL));
    return mix64(h ^ ((uint64_t)c * 0xa0761d6478bd642fULL));
}

/* The k-th uniform [0, 1) drawn from a feature hash. */
static inline double hash_unit(uint64_t h, unsigned k)
{
    return (double)(mix64(h + k * 0x9e3779b97f4a7c15ULL) >> 11) * 0x1.0p-53;
}

/* The scan's random stream: splitmix64 (a Weyl sequence through mix64;
 * passes BigCrush), a third of the cost of xoshiro256** per draw. */
typedef struct rng { uint64_t state; } rng;

static void rng_seed(rng *r, uint64_t seed) { r->state = mix64(seed ^ 0x5eed5eed5eed5eedULL); }

static inline uint64_t rng_next(rng *r)
{
    r->state += 0x9e3779b97f4a7c15ULL;
    return mix64(r->state);
}

static inline double rng_unit(rng *r) { return (double)(rng_next(r) >> 11) * 0x1.0p-53; }

/* Triangular noise in (-1, 1), standard deviation 0.41, from 32 random bits
 * (the sum of two 16-bit uniforms): two noise values per draw. */
static inline double tri_noise(uint32_t bits)
{
    return ((double)(bits & 0xffff) + (double)(bits >> 16)) * (1.0 / 65536) - 1.0;
}

/* ------------------------------------------------------------ fast math */

static inline double min2(double a, double b) { return a < b ? a : b; }
static inline double max2(double a, double b) { return a > b ? a : b; }

/* sin(2 pi t) for t >= 0 by linear interpolation in a table of one cycle:
 * error < 5e-6, so under 0.1 mm on the terrain's 8 m wave. The terrain is
 * evaluated for every pulse; this costs a fifth of a polynomial. */
#define SINE_STEPS 1024

static inline double sin_table(const double *tab, double t)
{
    double u = t * SINE_STEPS;
    int64_t i = (int64_t)u;
    double f = u - (double)i;
    const double *p = tab + (i & (SINE_STEPS - 1));
    return p[0] + f * (p[1] - p[0]);
}

static inline double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

/* ------------------------------------------------------------ scene */

#define NWAVES 4

typedef struct scene {
    uint64_t seed;
    double side;                 /* L */
    double grid0;                /* local position of the block grid origin (x and y),
                                    < -2 blocks so block coordinates are positive */
    int64_t centre_block;        /* index (x and y) of the block at the centre */
    int max_floors;              /* buildings stay below the aircraft */
    double tallest;              /* highest roof above its base */
    double wave_kx[NWAVES], wave_ky[NWAVES], wave_amp[NWAVES], wave_phase[NWAVES];
    double sine[SINE_STEPS + 1]; /* sin(2 pi i / SINE_STEPS) */
} scene;

static void scene_init(scene *sc, uint64_t seed, uint64_t points)
{
    static const double wavelength[NWAVES] = {2500, 900, 300, 110};
    static const double amplitude[NWAVES] = {8, 3, 1, 0.3};
    memset(sc, 0, sizeof *sc);
    sc->seed = seed;
    sc->side = max2(MIN_SIDE, sqrt((double)points / DENSITY));
    /* The centre of the scene is the centre of block (centre_block, centre_block). */
    double centred = sc->side / 2 - (STREET_WIDTH + (BLOCK_PERIOD - STREET_WIDTH) / 2);
    sc->centre_block = (int64_t)ceil(centred / BLOCK_PERIOD) + 2;
    sc->grid0 = centred - (double)sc->centre_block * BLOCK_PERIOD;
    sc->max_floors = MAX_FLOORS;
    sc->tallest = MAX_FLOORS * FLOOR_HEIGHT + 1.0;
    for (int i = 0; i <= SINE_STEPS; i++)
        sc->sine[i] = sin(6.283185307179586 * i / SINE_STEPS);
    for (int i = 0; i < NWAVES; i++) {
        uint64_t h = feature_hash(seed, 1, i, 0, 0);
        double dir = hash_unit(h, 0) * 6.283185307179586;
        sc->wave_kx[i] = cos(dir) / wavelength[i];
        sc->wave_ky[i] = sin(dir) / wavelength[i];
        sc->wave_amp[i] = amplitude[i] * (0.7 + 0.6 * hash_unit(h, 1));
        /* 2^20 whole cycles keep every argument of sin_table positive
         * for scenes up to 10^8 m (costs 2e-10 cycles of precision). */
        sc->wave_phase[i] = 1048576.0 + hash_unit(h, 2);
    }
}

static inline double terrain(const scene *sc, double x, double y)
{
    double z = GROUND_LEVEL;
    for (int i = 0; i < NWAVES; i++)
        z += sc->wave_amp[i] * sin_table(sc->sine, sc->wave_kx[i] * x + sc->wave_ky[i] * y +
                                                      sc->wave_phase[i]);
    return z;
}

/* Keeps the buildings below MAX_HEIGHT_SHARE of the flying height: small
 * scenes are flown low, and a roof closer to the aircraft than that would
 * fall between the strips' swaths (a hole in the roof). */
static void scene_fit_under(scene *sc, double height)
{
    int floors = (int)((height * MAX_HEIGHT_SHARE - 1.0) / FLOOR_HEIGHT);
    sc->max_floors = floors < 1 ? 1 : floors < MAX_FLOORS ? floors : MAX_FLOORS;
    double gable = 3 * FLOOR_HEIGHT + 1.0 + MAX_GABLE_SLOPE * GABLE_MAX_SPAN / 2;
    sc->tallest = max2(sc->max_floors * FLOOR_HEIGHT + 1.0, gable);
}

/* Where a local position falls in the block grid. */
typedef struct block_pos {
    int64_t bi, bj;              /* block indices */
    double u, v;                 /* position within the block period, [0, BLOCK_PERIOD) */
} block_pos;

static inline block_pos locate(const scene *sc, double x, double y)
{
    block_pos p;
    /* Positive for every position a ray reaches (x, y > -2 blocks). */
    double gx = (x - sc->grid0) * (1.0 / BLOCK_PERIOD), gy = (y - sc->grid0) * (1.0 / BLOCK_PERIOD);
    double fx = (double)(int64_t)gx, fy = (double)(int64_t)gy;
    p.bi = (int64_t)fx, p.bj = (int64_t)fy;
    p.u = (gx - fx) * BLOCK_PERIOD, p.v = (gy - fy) * BLOCK_PERIOD;
    return p;
}

static inline int in_street(const block_pos *p) { return p->u < STREET_WIDTH || p->v < STREET_WIDTH; }

/* What a block holds. Kept in a one-entry cache per kind of lookup:
 * consecutive pulses nearly always fall in the same block. */
typedef struct block_info {
    int64_t bi, bj;
    int valid;
    int park;                    /* no buildings, trees on a grid */
    int nx, ny;                  /* lots across x and y */
} block_info;

static const block_info *block_at(const scene *sc, block_info *cache, int64_t bi, int64_t bj)
{
    if (cache->valid && cache->bi == bi && cache->bj == bj)
        return cache;
    uint64_t h = feature_hash(sc->seed, 2, bi, bj, 0);
    cache->bi = bi, cache->bj = bj, cache->valid = 1;
    cache->park = (bi != sc->centre_block || bj != sc->centre_block) &&  /* centre built */
                  hash_unit(h, 0) < PARK_SHARE;
    cache->nx = 1 + (int)(hash_unit(h, 1) * 3);
    cache->ny = 1 + (int)(hash_unit(h, 2) * 3);
    return cache;
}

/* ---- buildings */

enum roof_kind { ROOF_FLAT, ROOF_RIDGE_X, ROOF_RIDGE_Y };

typedef struct building {
    int64_t bi, bj; int li, lj;  /* identity, for the cache */
    int valid;                   /* cache slot filled */
    double lx0, lx1, ly0, ly1;   /* the lot */
    double x0, x1, y0, y1;       /* footprint */
    double zb, ze;               /* base, eaves (flat roof height) */
    double slope;                /* gable rise per metre from the eaves */
    int roof;
    double shade;                /* roof colour/intensity factor */
} building;

/* Fills b with the building of lot (li, lj) of block (bi, bj). */
static void make_building(const scene *sc, building *b, int64_t bi, int64_t bj, int li, int lj,
                          int nx, int ny)
{
    uint64_t h = feature_hash(sc->seed, 3, bi, bj, li * 4 + lj);
    double lw = (BLOCK_PERIOD - STREET_WIDTH) / nx, lh = (BLOCK_PERIOD - STREET_WIDTH) / ny;
    double lx = sc->grid0 + bi * BLOCK_PERIOD + STREET_WIDTH + li * lw;
    double ly = sc->grid0 + bj * BLOCK_PERIOD + STREET_WIDTH + lj * lh;
    double room_x = lw - 2 * LOT_SETBACK, room_y = lh - 2 * LOT_SETBACK;
    double w = room_x * (0.55 + 0.45 * hash_unit(h, 0)), d = room_y * (0.55 + 0.45 * hash_unit(h, 1));
    b->bi = bi, b->bj = bj, b->li = li, b->lj = lj, b->valid = 1;
    b->lx0 = lx, b->lx1 = lx + lw, b->ly0 = ly, b->ly1 = ly + lh;
    b->x0 = lx + LOT_SETBACK + (room_x - w) * hash_unit(h, 2), b->x1 = b->x0 + w;
    b->y0 = ly + LOT_SETBACK + (room_y - d) * hash_unit(h, 3), b->y1 = b->y0 + d;
    double u = hash_unit(h, 4);
    int floors = 1 + (int)(u * u * u * 9);
    if (hash_unit(h, 5) < 0.06)  /* a tower */
        floors += 6 + (int)(hash_unit(h, 6) * (MAX_FLOORS - 9));
    floors = floors < sc->max_floors ? floors : sc->max_floors;
    b->zb = terrain(sc, (b->x0 + b->x1) / 2, (b->y0 + b->y1) / 2) - 0.3;
    b->ze = b->zb + 0.3 + floors * FLOOR_HEIGHT + 0.6 * hash_unit(h, 7);
    b->roof = ROOF_FLAT, b->slope = 0;
    if (floors <= 3 && (w < d ? w : d) <= GABLE_MAX_SPAN && hash_unit(h, 8) < 0.7) {
        b->roof = w >= d ? ROOF_RIDGE_X : ROOF_RIDGE_Y;   /* ridge along the longer side */
        b->slope = 0.45 + (MAX_GABLE_SLOPE - 0.45) * hash_unit(h, 9);
    }
    b->shade = 0.75 + 0.5 * hash_unit(h, 10);
}

/* The building standing on the lot at (x, y), or NULL (street, park). The
 * caches hold the last block and building looked up; a scan line crosses a
 * lot in many consecutive pulses. */
static const building *building_at(const scene *sc, double x, double y, block_info *blocks,
                                   building *cache, int *street)
{
    if (cache->valid && x >= cache->lx0 && x < cache->lx1 && y >= cache->ly0 && y < cache->ly1) {
        *street = 0;             /* still on the cached lot */
        return cache;
    }
    block_pos p = locate(sc, x, y);
    *street = in_street(&p);
    if (*street)
        return NULL;
    const block_info *blk = block_at(sc, blocks, p.bi, p.bj);
    if (blk->park)
        return NULL;
    int nx = blk->nx, ny = blk->ny;
    double span = BLOCK_PERIOD - STREET_WIDTH;
    int li = (int)((p.u - STREET_WIDTH) * nx / span), lj = (int)((p.v - STREET_WIDTH) * ny / span);
    li = li < nx ? li : nx - 1, lj = lj < ny ? lj : ny - 1;
    if (!(cache->valid && cache->bi == p.bi && cache->bj == p.bj && cache->li == li &&
          cache->lj == lj))
        make_building(sc, cache, p.bi, p.bj, li, lj, nx, ny);
    return cache;
}

/* ---- trees */

typedef struct tree {
    int64_t key[4];              /* identity, for the cache */
    int valid, present;
    double cx, cy, zc;           /* crown centre */
    double rh, rv;               /* crown radii */
    double lobe, rot_c, rot_s;   /* outline: r * (1 + lobe * cos 3(phi - rot)) */
} tree;

static void make_tree(const scene *sc, tree *t, const int64_t key[4], double cx, double cy,
                      double slack, int park)
{
    uint64_t h = feature_hash(sc->seed, 4, key[0], key[1], key[2] * 64 + key[3]);
    memcpy(t->key, key, sizeof t->key);
    t->valid = 1;
    t->present = hash_unit(h, 0) < (park ? 0.65 : 0.75);
    t->rh = park ? 2.4 + 1.6 * hash_unit(h, 1) : 2.0 + 1.7 * hash_unit(h, 1);
    t->rv = t->rh * (0.8 + 0.6 * hash_unit(h, 2));
    slack -= t->rh * 1.15;       /* keep the crown in its slot */
    if (slack > 0) {
        cx += slack * (2 * hash_unit(h, 3) - 1);
        cy += slack * (2 * hash_unit(h, 4) - 1);
    }
    t->cx = cx, t->cy = cy;
    t->zc = terrain(sc, cx, cy) + 2.0 + 3.0 * hash_unit(h, 5) + t->rv;
    t->lobe = 0.05 + 0.1 * hash_unit(h, 6);
    /* Outline orientation: cos/sin of the 6 angles 0, 20 .. 100 degrees
     * (the three lobes repeat every 120), without libm in this hot path. */
    static const double rot[6][2] = {
        {1, 0}, {0.9396926, 0.3420201}, {0.7660444, 0.6427876},
        {0.5, 0.8660254}, {0.1736482, 0.9848078}, {-0.1736482, 0.9848078}};
    int k = (int)(hash_unit(h, 7) * 6);
    t->rot_c = rot[k][0], t->rot_s = rot[k][1];
}

static const tree *cached_tree(const scene *sc, tree *cache, int64_t a, int64_t b, int64_t c,
                               int64_t d, double cx, double cy, double slack, int park)
{
    int64_t key[4] = {a, b, c, d};
    if (!cache->valid || memcmp(cache->key, key, sizeof key))
        make_tree(sc, cache, key, cx, cy, slack, park);
    return cache->present ? cache : NULL;
}

/* The street tree whose kerb line runs along axis 0 (x varies: u across the
 * street is p->v) or 1, near position (u across, v along) of a block; NULL if
 * none within reach. Block-local coordinates are mapped back to local x, y. */
static const tree *street_tree(const scene *sc, const block_pos *p, int axis, tree *cache)
{
    double across = axis ? p->u : p->v, along = axis ? p->v : p->u;
    int64_t bi = p->bi, bj = p->bj;
    /* Kerb lines at 2.5 and 13.5 in this period, and 2.5 of the next one. */
    double lines[3] = {KERB_OFFSET, STREET_WIDTH - KERB_OFFSET, BLOCK_PERIOD + KERB_OFFSET};
    int k = across < (lines[0] + lines[1]) / 2 ? 0 : across < (lines[1] + lines[2]) / 2 ? 1 : 2;
    if (fabs(across - lines[k]) > TREE_MAX_REACH || along < STREET_WIDTH)
        return NULL;
    int slot = (int)((along - STREET_WIDTH) / TREE_SLOT);
    double line = lines[k];
    if (k == 2) {                /* the next period's first line */
        line = KERB_OFFSET, k = 0;
        if (axis) bi++; else bj++;
    }
    double base_x = sc->grid0 + bi * BLOCK_PERIOD, base_y = sc->grid0 + bj * BLOCK_PERIOD;
    double c_along = STREET_WIDTH + (slot + 0.5) * TREE_SLOT;
    double cx = base_x + (axis ? line : c_along), cy = base_y + (axis ? c_along : line);
    /* Street trees are planted on a regular line: no jitter. */
    return cached_tree(sc, cache, bi, bj, axis * 2 + k, slot, cx, cy, 0, 0);
}

static const tree *park_tree(const scene *sc, const block_pos *p, tree *cache)
{
    int ci = (int)((p->u - STREET_WIDTH) / TREE_SLOT), cj = (int)((p->v - STREET_WIDTH) / TREE_SLOT);
    double cx = sc->grid0 + p->bi * BLOCK_PERIOD + STREET_WIDTH + (ci + 0.5) * TREE_SLOT;
    double cy = sc->grid0 + p->bj * BLOCK_PERIOD + STREET_WIDTH + (cj + 0.5) * TREE_SLOT;
    return cached_tree(sc, cache, p->bi, p->bj, 8, ci * 16 + cj, cx, cy, TREE_SLOT / 2, 1);
}

static inline double dist2(double x, double y, const tree *t)
{
    return (x - t->cx) * (x - t->cx) + (y - t->cy) * (y - t->cy);
}

static const tree *nearer(double x, double y, const tree *a, const tree *b)
{
    if (!a || !b)
        return a ? a : b;
    return dist2(x, y, a) <= dist2(x, y, b) ? a : b;
}

/* The tree whose crown may cover (x, y): the nearest of the park tree of
 * the cell and the street trees of the two kerb directions that can reach
 * it. caches[0..2] are per kind (two kerb directions, park). */
static const tree *tree_at(const scene *sc, double x, double y, block_info *blocks,
                          tree caches[3])
{
    block_pos p = locate(sc, x, y);
    const tree *t = NULL;
    if (p.u >= STREET_WIDTH && p.v >= STREET_WIDTH && block_at(sc, blocks, p.bi, p.bj)->park)
        t = park_tree(sc, &p, &caches[2]);
    const double reach_in = TREE_MAX_REACH - KERB_OFFSET;   /* street crowns into a block */
    if (p.u >= STREET_WIDTH + reach_in && p.v >= STREET_WIDTH + reach_in &&
        p.u <= BLOCK_PERIOD - reach_in && p.v <= BLOCK_PERIOD - reach_in)
        return t;                /* inside a block, out of the street trees' reach */
    t = nearer(x, y, t, street_tree(sc, &p, 1, &caches[0]));
    return nearer(x, y, t, street_tree(sc, &p, 0, &caches[1]));
}

/* ------------------------------------------------------------ ray tracing */

/* A pulse: a straight ray from the aircraft at (xa, y, za) leaning across
 * track; descending by 1 m moves it s metres in x. */
typedef struct ray { double xa, y, za, s; } ray;

static inline double ray_x(const ray *r, double z) { return r->xa + (r->za - z) * r->s; }

typedef struct hit { double x, z; int material; double shade; } hit;

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

/* Vertical extent of the crown along the ray (treated as vertical inside
 * the crown); 0 if the ray misses it. */
static int crown_chord(const tree *t, const ray *r, double *top, double *bottom)
{
    double x = ray_x(r, t->zc), dx = x - t->cx, dy = r->y - t->cy;
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

/* ------------------------------------------------------------ the pulse */

/* One return, in local coordinates, before the acquisition attributes. */
typedef struct echo { double x, z; int material; double shade; } echo;

/* Per-scan lookup state: caches of scene features (each lookup kind its
 * own, so they do not evict each other) and the last ground height. */
typedef struct tracer {
    const scene *sc;
    block_info blocks[3];        /* ground lot, roof-level lot, tree lookups */
    building lots[2];            /* lot under the ground hit, lot at roof level */
    tree trees[3];               /* two kerb directions, park */
    double ground_guess;         /* ground height of the previous pulse */
} tracer;

/* 1 if (x, y) lies on the cached lot, at least `margin` inside it. */
static inline int inside_lot(const building *b, double x, double y, double margin)
{
    return b->valid && x >= b->lx0 + margin && x < b->lx1 - margin && y >= b->ly0 + margin &&
           y < b->ly1 - margin;
}

/* The first surface the ray meets below the tree tops: ground or building. */
static hit trace_solid(tracer *tr, const ray *r)
{
    const scene *sc = tr->sc;
    /* Where the ray meets the terrain: one step from the previous pulse's
     * height (neighbouring pulses differ by centimetres); the point is on
     * the terrain, off the ray by far less than the ranging noise. */
    double x = ray_x(r, tr->ground_guess);
    double z = terrain(sc, x, r->y);
    tr->ground_guess = z;
    int street, street_top;
    hit best = {x, z, MAT_GROUND, 1.0}, h;
    const building *b = building_at(sc, x, r->y, &tr->blocks[0], &tr->lots[0], &street);
    if (street)
        best.material = MAT_STREET;
    if (b && building_hit(b, r, &h) && h.z > best.z)
        best = h;
    const building *b2 = building_at(sc, ray_x(r, z + sc->tallest), r->y, &tr->blocks[1],
                                     &tr->lots[1], &street_top);
    if (b2 && !(b && b2->bi == b->bi && b2->bj == b->bj && b2->li == b->li && b2->lj == b->lj) &&
        building_hit(b2, r, &h) && h.z > best.z)
        best = h;
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
        out[i] = (echo){ray_x(r, z), z, MAT_TREE, 1.0};
    }
    if (last_on_solid)
        out[n - 1] = (echo){solid->x, solid->z, solid->material, solid->shade};
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
        out[0] = (echo){ray_x(r, z), z, MAT_NOISE, 1.0};
        return 1;
    }
    /* Built lots hold no trees: only street crowns reach a little way in. */
    double probe = ray_x(r, solid.z + CROWN_PROBE);
    const tree *t = NULL;
    if (!inside_lot(&tr->lots[0], probe, r->y, TREE_MAX_REACH - KERB_OFFSET))
        t = tree_at(sc, probe, r->y, &tr->blocks[2], tr->trees);
    double top, bottom;
    if (t && crown_chord(t, r, &top, &bottom) && top > solid.z + 0.5)
        return crown_echoes(g, r, &solid, top, bottom, out);
    out[0] = (echo){solid.x, solid.z, solid.material, solid.shade};
    return 1;
}

/* Traces one pulse; returns the number of echoes, or 0 when one of them
 * falls outside the scene square (the whole pulse is then not recorded, so
 * the bounds are the scene's and every recorded pulse is complete). */
static int trace_pulse(tracer *tr, rng *g, const ray *r, echo out[MAX_RETURNS])
{
    int n = trace_echoes(tr, g, r, out);
    for (int i = 0; i < n; i++)
        if (out[i].x < 0 || out[i].x > tr->sc->side)
            return 0;
    return n;
}

/* ------------------------------------------------------------ output */

/* Point data record format 3 (LAS 1.2): byte offsets of its fields. */
enum las3_layout {
    L3_X = 0, L3_Y = 4, L3_Z = 8, L3_INTENSITY = 12,
    L3_RETURNS = 14,             /* return 0-2, number of returns 3-5, scan direction 6, edge 7 */
    L3_CLASS = 15,               /* class 0-4, synthetic 5, key point 6, withheld 7 */
    L3_ANGLE = 16, L3_USER = 17, L3_SOURCE = 18, L3_GPS = 20,
    L3_RED = 28, L3_GREEN = 30, L3_BLUE = 32, L3_SIZE = 34
};

/* The PLY vertex: double x y z, ushort intensity, uchar return_number,
 * number_of_returns, classification, ushort point_source_id, double
 * gps_time, uchar red green blue, packed. */
enum ply_layout {
    P_X = 0, P_Y = 8, P_Z = 16, P_INTENSITY = 24, P_RETURN = 26, P_NRETURNS = 27,
    P_CLASS = 28, P_SOURCE = 29, P_GPS = 31, P_RED = 39, P_GREEN = 40, P_BLUE = 41, P_SIZE = 42
};

typedef struct field_def {
    const char *name;
    wpd_type type;
    uint32_t offset;
    uint8_t bit_shift, bit_count;
} field_def;

static const field_def las3_fields[] = {
    {"intensity", WPD_U16, L3_INTENSITY, 0, 0},
    {"return_number", WPD_U8, L3_RETURNS, 0, 3},
    {"number_of_returns", WPD_U8, L3_RETURNS, 3, 3},
    {"scan_direction_flag", WPD_U8, L3_RETURNS, 6, 1},
    {"edge_of_flight_line", WPD_U8, L3_RETURNS, 7, 1},
    {"classification", WPD_U8, L3_CLASS, 0, 5},
    {"synthetic", WPD_U8, L3_CLASS, 5, 1},
    {"key_point", WPD_U8, L3_CLASS, 6, 1},
    {"withheld", WPD_U8, L3_CLASS, 7, 1},
    {"scan_angle_rank", WPD_I8, L3_ANGLE, 0, 0},
    {"user_data", WPD_U8, L3_USER, 0, 0},
    {"point_source_id", WPD_U16, L3_SOURCE, 0, 0},
    {"gps_time", WPD_F64, L3_GPS, 0, 0},
    {"red", WPD_U16, L3_RED, 0, 0},
    {"green", WPD_U16, L3_GREEN, 0, 0},
    {"blue", WPD_U16, L3_BLUE, 0, 0},
};

static const field_def ply_fields[] = {
    {"x", WPD_F64, P_X, 0, 0},
    {"y", WPD_F64, P_Y, 0, 0},
    {"z", WPD_F64, P_Z, 0, 0},
    {"intensity", WPD_U16, P_INTENSITY, 0, 0},
    {"return_number", WPD_U8, P_RETURN, 0, 0},
    {"number_of_returns", WPD_U8, P_NRETURNS, 0, 0},
    {"classification", WPD_U8, P_CLASS, 0, 0},
    {"point_source_id", WPD_U16, P_SOURCE, 0, 0},
    {"gps_time", WPD_F64, P_GPS, 0, 0},
    {"red", WPD_U8, P_RED, 0, 0},
    {"green", WPD_U8, P_GREEN, 0, 0},
    {"blue", WPD_U8, P_BLUE, 0, 0},
};

static void add_fields(wpd_schema *s, const field_def *f, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        wpd_dim *d = &s->dims[wpd_schema_add(s, f[i].name, f[i].type, f[i].offset)];
        d->bit_shift = f[i].bit_shift, d->bit_count = f[i].bit_count;
    }
}

/* The PDRF 3 schema: x y z i32 scaled by scale/offset, then the standard
 * fields with their laspy/PDAL names (the names the LAS reader uses). */
static void las_schema(wpd_schema *s, const double scale[3], const double offset[3])
{
    static const char *const axis[3] = {"x", "y", "z"};
    memset(s, 0, sizeof *s);
    for (int k = 0; k < 3; k++) {
        wpd_dim *d = &s->dims[wpd_schema_add(s, axis[k], WPD_I32, L3_X + 4 * k)];
        d->scaled = 1, d->scale = scale[k], d->add = offset[k];
    }
    s->dim_x = 0, s->dim_y = 1, s->dim_z = 2;
    add_fields(s, las3_fields, sizeof las3_fields / sizeof *las3_fields);
    s->record_size = L3_SIZE;
}

static void ply_schema(wpd_schema *s)
{
    memset(s, 0, sizeof *s);
    add_fields(s, ply_fields, sizeof ply_fields / sizeof *ply_fields);
    s->dim_x = 0, s->dim_y = 1, s->dim_z = 2;
    s->record_size = P_SIZE;
}

typedef struct tile_out {
    wpd_writer *w;
    wpd_batch b;
    char path[1024];
} tile_out;

typedef struct emitter {
    const wpd_synth_options *opt;
    wpd_header hdr;
    int las;                        /* LAS PDRF 3 records, else PLY vertices */
    tile_out *tiles;
    int ntiles, columns, rows;
    double side;
    uint64_t written, target;
    int64_t kmin[3], kmax[3];       /* bounds in 0.01 m steps */
} emitter;

/* GeoTIFF keys of the LAS projection VLR: WGS 84 / UTM zone 18N (the
 * origin 500000 E 4500000 N lies near New York), metres. */
static const uint16_t geo_keys[] = {
    1, 1, 0, 5,                  /* directory version, revision, minor, key count */
    1024, 0, 1, 1,               /* GTModelType: projected */
    1025, 0, 1, 1,               /* GTRasterType: pixel is area */
    3072, 0, 1, 32618,           /* ProjectedCSType: EPSG 32618 */
    3076, 0, 1, 9001,            /* ProjLinearUnits: metre */
    4099, 0, 1, 9001,            /* VerticalUnits: metre */
};

/* Fills e->hdr for the output format; pointers in it refer to static data
 * and e-owned buffers (the writer deep-copies the header). */
static void build_header(emitter *e, wpd_vlr *vlr, uint8_t *vlr_data, char **comments,
                         char comment_buf[2][128])
{
    wpd_header *h = &e->hdr;
    memset(h, 0, sizeof *h);
    h->format = e->opt->format;
    if (h->format == WPD_FMT_LAS) {
        wpd_las_info *las = &h->las;
        /* LAS 1.2 holds at most 2^32 - 1 points; beyond, 1.4 (which still
         * allows point format 3) with its 64-bit counts. */
        int v14 = e->opt->points > UINT32_MAX;
        las->version_major = 1, las->version_minor = v14 ? 4 : 2, las->pdrf = 3;
        las->record_length = L3_SIZE, las->header_size = v14 ? 375 : 227;
        las->global_encoding = 1;               /* adjusted standard GPS time */
        snprintf(las->system_id, sizeof las->system_id, "wpd synth");
        snprintf(las->software, sizeof las->software, "wpd synth");
        las->creation_day = 1, las->creation_year = 2025;
        for (int k = 0; k < 3; k++)
            las->scale[k] = COORD_SCALE;
        las->offset[0] = ORIGIN_X, las->offset[1] = ORIGIN_Y, las->offset[2] = 0;
        memset(vlr, 0, sizeof *vlr);
        snprintf(vlr->user_id, sizeof vlr->user_id, "LASF_Projection");
        vlr->record_id = 34735;
        vlr->length = sizeof geo_keys;
        snprintf(vlr->description, sizeof vlr->description, "GeoKeyDirectoryTag");
        for (size_t i = 0; i < sizeof geo_keys / sizeof *geo_keys; i++) {
            vlr_data[2 * i] = (uint8_t)(geo_keys[i] & 0xff);
            vlr_data[2 * i + 1] = (uint8_t)(geo_keys[i] >> 8);
        }
        vlr->data = vlr_data;
        las->nvlr = 1, las->vlrs = vlr;
        las->offset_to_points = las->header_size + 54 + (uint32_t)sizeof geo_keys;
        las_schema(&h->schema, las->scale, las->offset);
        e->las = 1;
    } else {
        h->ply.encoding = e->opt->ply_ascii ? WPD_PLY_ASCII : WPD_PLY_BINARY_LE;
        snprintf(comment_buf[0], 128, "wpd synth: synthetic city scan, seed %" PRIu64 ", %" PRIu64
                 " points", e->opt->seed, e->opt->points);
        snprintf(comment_buf[1], 128, "wpd synth: x y z in metres, WGS 84 / UTM zone 18N (EPSG:32618)");
        comments[0] = comment_buf[0], comments[1] = comment_buf[1];
        h->ply.comments = comments, h->ply.ncomments = 2;
        ply_schema(&h->schema);
    }
}

/* A point with its acquisition attributes, each within its field's range. */
typedef struct point {
    double x, y, z;              /* local */
    double gps_time;
    int intensity, ret, nret, scan_dir, edge, cls, angle, source;
    int rgb[3];                  /* 8-bit */
} point;

static inline void put_u16(uint8_t *p, int v)
{
    uint16_t x = (uint16_t)v;
    memcpy(p, &x, 2);
}

/* Record encoders, one per layout above. Direct stores: generic setters
 * (wpd_dim_set) for the 12 fields would cost a third of the run time. The
 * writers fill x y z from the batch's xyz (the PLY ones are set here too). */
static inline void encode_las3(uint8_t *rec, const point *p)
{
    put_u16(rec + L3_INTENSITY, p->intensity);
    rec[L3_RETURNS] = (uint8_t)(p->ret | p->nret << 3 | p->scan_dir << 6 | p->edge << 7);
    rec[L3_CLASS] = (uint8_t)p->cls;
    rec[L3_ANGLE] = (uint8_t)(int8_t)p->angle;
    rec[L3_USER] = 0;
    put_u16(rec + L3_SOURCE, p->source);
    memcpy(rec + L3_GPS, &p->gps_time, 8);
    put_u16(rec + L3_RED, p->rgb[0] * 257);     /* 8-bit to 16-bit colour */
    put_u16(rec + L3_GREEN, p->rgb[1] * 257);
    put_u16(rec + L3_BLUE, p->rgb[2] * 257);
}

static inline void encode_ply(uint8_t *rec, const point *p, const double xyz[3])
{
    memcpy(rec + P_X, xyz, 24);
    put_u16(rec + P_INTENSITY, p->intensity);
    rec[P_RETURN] = (uint8_t)p->ret;
    rec[P_NRETURNS] = (uint8_t)p->nret;
    rec[P_CLASS] = (uint8_t)p->cls;
    put_u16(rec + P_SOURCE, p->source);
    memcpy(rec + P_GPS, &p->gps_time, 8);
    rec[P_RED] = (uint8_t)p->rgb[0];
    rec[P_GREEN] = (uint8_t)p->rgb[1];
    rec[P_BLUE] = (uint8_t)p->rgb[2];
}

static int flush_tile(tile_out *t, wpd_error *err)
{
    if (!t->b.n)
        return 0;
    int rc = wpd_writer_write(t->w, &t->b, err);
    t->b.n = 0;
    return rc;
}

/* v rounded to the coordinate grid, in grid steps; v >= 0 (local x, y are
 * within the scene square, z is an elevation of about 100 m or more). */
static inline int64_t to_steps(double v) { return (int64_t)(v * (1.0 / COORD_SCALE) + 0.5); }

/* Rounds p to the coordinate grid, routes it to its tile, encodes it. */
static int emit_point(emitter *e, const point *p, wpd_error *err)
{
    int64_t k[3] = {to_steps(p->x), to_steps(p->y), to_steps(p->z)};
    int col = 0, row = 0;
    if (e->ntiles > 1) {
        col = (int)((double)k[0] * COORD_SCALE * e->columns / e->side);
        row = (int)((double)k[1] * COORD_SCALE * e->rows / e->side);
        col = col < 0 ? 0 : col >= e->columns ? e->columns - 1 : col;
        row = row < 0 ? 0 : row >= e->rows ? e->rows - 1 : row;
    }
    tile_out *t = &e->tiles[row * e->columns + col];
    uint8_t *rec = t->b.records + t->b.n * (size_t)t->b.record_size;
    double *xyz = t->b.xyz + 3 * t->b.n;
    xyz[0] = ORIGIN_X + (double)k[0] * COORD_SCALE;
    xyz[1] = ORIGIN_Y + (double)k[1] * COORD_SCALE;
    xyz[2] = (double)k[2] * COORD_SCALE;
    if (e->las)
        encode_las3(rec, p);
    else
        encode_ply(rec, p, xyz);
    for (int a = 0; a < 3; a++) {
        if (k[a] < e->kmin[a]) e->kmin[a] = k[a];
        if (k[a] > e->kmax[a]) e->kmax[a] = k[a];
    }
    e->written++;
    if (++t->b.n == t->b.cap)
        return flush_tile(t, err);
    return 0;
}

/* Most square columns x rows == k with columns >= rows. */
static void tile_grid(int k, int *columns, int *rows)
{
    int r = 1;
    for (int d = 1; (long)d * d <= k; d++)
        if (k % d == 0)
            r = d;
    *rows = r, *columns = k / r;
}

int wpd_synth_tile_path(const char *output, int t, char *buf, size_t len)
{
    const char *base = strrchr(output, '/');
    base = base ? base + 1 : output;
    const char *dot = strrchr(base, '.');
    size_t stem = dot && dot != base ? (size_t)(dot - output) : strlen(output);
    int n = snprintf(buf, len, "%.*s_tile%d%s", (int)stem, output, t, output + stem);
    return n < 0 || (size_t)n >= len ? -1 : 0;
}

static void emitter_abort(emitter *e)
{
    for (int i = 0; e->tiles && i < e->ntiles; i++) {
        wpd_writer_abort(e->tiles[i].w);
        wpd_batch_free(&e->tiles[i].b);
    }
    free(e->tiles);
    e->tiles = NULL;
}

static int emitter_open(emitter *e, const wpd_synth_options *opt, double side, wpd_error *err,
                        wpd_vlr *vlr, uint8_t *vlr_data, char **comments, char cbuf[2][128])
{
    memset(e, 0, sizeof *e);
    e->opt = opt, e->side = side, e->target = opt->points;
    e->ntiles = opt->tiles > 1 ? opt->tiles : 1;
    tile_grid(e->ntiles, &e->columns, &e->rows);
    for (int a = 0; a < 3; a++)
        e->kmin[a] = INT64_MAX, e->kmax[a] = INT64_MIN;
    build_header(e, vlr, vlr_data, comments, cbuf);
    e->tiles = calloc((size_t)e->ntiles, sizeof *e->tiles);
    if (!e->tiles)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", opt->output);
    size_t cap = BATCH_BUDGET / e->ntiles;
    cap = cap > BATCH_POINTS ? BATCH_POINTS : cap < 1024 ? 1024 : cap;
    if (cap > opt->points)
        cap = (size_t)opt->points;
    wpd_write_options wo = {.ply_ascii = opt->ply_ascii, .overwrite = opt->overwrite};
    for (int i = 0; i < e->ntiles; i++) {
        tile_out *t = &e->tiles[i];
        if (e->ntiles == 1)
            snprintf(t->path, sizeof t->path, "%s", opt->output);
        else if (wpd_synth_tile_path(opt->output, i + 1, t->path, sizeof t->path))
            return wpd_fail(err, WPD_E_USAGE, "%s: output path too long", opt->output);
        if (wpd_batch_init(&t->b, cap, e->hdr.schema.record_size))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", t->path);
        memset(t->b.records, 0, cap * e->hdr.schema.record_size);
        if (!(t->w = wpd_writer_open(t->path, &e->hdr, &wo, err)))
            return -1;
    }
    return 0;
}

/* Flushes and commits every tile; on failure removes the others too. */
static int emitter_close(emitter *e, wpd_error *err)
{
    for (int i = 0; i < e->ntiles; i++)
        if (flush_tile(&e->tiles[i], err))
            return -1;
    for (int i = 0; i < e->ntiles; i++) {
        wpd_writer *w = e->tiles[i].w;
        e->tiles[i].w = NULL;
        if (wpd_writer_close(w, err)) {
            /* The tiles committed so far are complete, but a partial set is
             * useless: remove them. */
            for (int j = 0; j < i; j++)
                remove(e->tiles[j].path);
            return -1;
        }
    }
    return 0;
}

/* ------------------------------------------------------------ the flight */

typedef struct flight {
    double swath, height, spacing;   /* strip geometry */
    double altitude;                 /* of the aircraft: height above the scene centre */
    int strips;
    double first_centre;
    int pulses_per_line;             /* M */
    double *tan_of;                  /* [M]: tangent of the scan angle of step j */
    int8_t *rank_of;                 /* [M]: angle in whole degrees */
    double *gain_of;                 /* [M]: intensity factor of the incidence */
    int *lo, *hi;                    /* per strip: steps landing in or near the scene */
    int *inside;                     /* per strip: steps landing in the scene */
    double line_spacing;             /* nominal along-track spacing (m) */
    double line_period;              /* seconds per scan line */
} flight;

static void flight_free(flight *f)
{
    free(f->tan_of), free(f->rank_of), free(f->gain_of), free(f->lo), free(f->hi), free(f->inside);
    memset(f, 0, sizeof *f);
}

static double strip_centre(const flight *f, int i) { return f->first_centre + i * f->spacing; }

/* Plans strips and scan pattern for the scene and the target count. */
static int flight_plan(flight *f, const scene *sc, uint64_t points)
{
    double L = sc->side;
    memset(f, 0, sizeof *f);
    f->swath = clampd(L / (1 + (MIN_STRIPS - 1) * (1 - SIDE_OVERLAP)), SWATH_MIN, SWATH_MAX);
    f->spacing = f->swath * (1 - SIDE_OVERLAP);
    f->strips = (int)ceil((L - f->swath) / f->spacing - 1e-9) + 1;
    if (f->strips < MIN_STRIPS)
        f->strips = MIN_STRIPS;
    f->first_centre = L / 2 - (f->strips - 1) * f->spacing / 2;
    f->height = f->swath / 2 / tan(SCAN_HALF_ANGLE);
    f->altitude = terrain(sc, L / 2, L / 2) + f->height;
    /* Scene area seen per strip, to set the pulse spacing for N points. */
    double covered = 0;
    for (int i = 0; i < f->strips; i++) {
        double c = strip_centre(f, i);
        covered += max2(0, min2(L, c + f->swath / 2) - max2(0, c - f->swath / 2)) * L;
    }
    double pulses_per_m2 = (double)points / RETURNS_PRIOR / covered;
    double step = 1 / sqrt(pulses_per_m2);
    int m = (int)(f->swath / step + 0.5);
    f->pulses_per_line = m = m < 2 ? 2 : m > 1000000 ? 1000000 : m;
    f->line_spacing = step;
    f->line_period = step / clampd(GROUND_SPEED * f->swath / SWATH_MAX, MIN_GROUND_SPEED, GROUND_SPEED);
    f->tan_of = malloc(m * sizeof *f->tan_of);
    f->rank_of = malloc(m * sizeof *f->rank_of);
    f->gain_of = malloc(m * sizeof *f->gain_of);
    f->lo = malloc(f->strips * sizeof *f->lo);
    f->hi = malloc(f->strips * sizeof *f->hi);
    f->inside = malloc(f->strips * sizeof *f->inside);
    if (!f->tan_of || !f->rank_of || !f->gain_of || !f->lo || !f->hi || !f->inside)
        return -1;
    for (int j = 0; j < m; j++) {
        double a = SCAN_HALF_ANGLE * (2 * (j + 0.5) / m - 1);
        f->tan_of[j] = tan(a);
        f->rank_of[j] = (int8_t)lround(a * 180 / 3.14159265358979323846);
        f->gain_of[j] = 0.6 + 0.4 * cos(a);
    }
    /* Steps whose nominal ground point is near the scene (traced: the
     * terrain moves the actual one) and in it (the expected yield). */
    for (int i = 0; i < f->strips; i++) {
        double c = strip_centre(f, i);
        int lo = 0, hi = m, inside = 0;
        while (lo < m && c + f->height * f->tan_of[lo] < -5.0)
            lo++;
        while (hi > lo && c + f->height * f->tan_of[hi - 1] > L + 5.0)
            hi--;
        for (int j = lo; j < hi; j++) {
            double x = c + f->height * f->tan_of[j];
            inside += x >= 0 && x <= L;
        }
        f->lo[i] = lo, f->hi[i] = hi, f->inside[i] = inside;
    }
    return 0;
}

/* State of the scan in progress. */
typedef struct scan {
    const scene *sc;
    const flight *fl;
    emitter *em;
    tracer tr;
    rng g;
    uint64_t pulses;             /* in-scene pulses traced */
    uint64_t echoes;             /* their echoes */
    double time;                 /* gps time of the current line */
    int strips_used;
} scan;

/* Along-track spacing for the next line: what makes the points still needed
 * fit the scan still to fly, a few lines early (clamped to 0.5 .. 2 times
 * the nominal spacing; the exact stop is at the N-th point). */
static double next_line_spacing(const scan *s, int strip, double flown)
{
    const flight *f = s->fl;
    double need = (double)(s->em->target - s->em->written);
    double per_pulse = (s->echoes + RETURNS_PRIOR * 20000.0) / (s->pulses + 20000.0);
    double ahead = (double)f->inside[strip] * max2(0, s->sc->side - flown);
    for (int i = strip + 1; i < f->strips; i++)
        ahead += (double)f->inside[i] * s->sc->side;
    double margin = 3.0 * f->inside[strip] * per_pulse;
    double dy = ahead * per_pulse / (need + margin);
    return clampd(dy, 0.5 * f->line_spacing, 2.0 * f->line_spacing);
}

/* Class, intensity and colour of echo p->ret of p->nret: intensity by
 * surface, lower off nadir (gain) and for later returns of a split pulse,
 * with noise; colour by surface with a brightness and per-channel jitter. */
static void shade_point(rng *g, point *p, const echo *e, double gain, double noise)
{
    /* Share of the pulse energy of return r of a split pulse. */
    static const double split_energy[MAX_RETURNS + 1] = {0, 0.8, 0.275, 0.183, 0.138, 0.11};
    int m = e->material;
    double energy = p->nret > 1 ? split_energy[p->ret] : 1.0;
    double base = material_intensity[m] * (m == MAT_ROOF ? e->shade : 1.0);
    double i = base * energy * gain * (1 + 0.3 * noise);
    p->intensity = (int)clampd(i + 0.5, 0, 65535);
    /* Colour in integers: brightness 0.94 .. 1.06 (times the roof's shade,
     * 0.75 .. 1.25), then -8 .. +7 per channel. Every material colour stays
     * within 0 .. 255 after both. */
    uint64_t bits = rng_next(g);
    int tone = (int)((m == MAT_ROOF ? e->shade : 1.0) * (240 + (int)(bits & 31)));
    for (int c = 0; c < 3; c++)
        p->rgb[c] = ((material_rgb[m][c] * tone) >> 8) + (int)((bits >> (8 + 8 * c)) & 15) - 8;
    p->cls = material_class[m];
}

/* Emits the echoes of one pulse (stopping at the target count). */
static int emit_pulse(scan *s, point *p, const echo *ech, int n, double gain, wpd_error *err)
{
    emitter *em = s->em;
    p->nret = n;
    for (int i = 0; i < n && em->written < em->target; i++) {
        uint64_t bits = rng_next(&s->g);
        p->ret = i + 1;
        p->x = ech[i].x;
        p->z = ech[i].z + 0.05 * tri_noise((uint32_t)bits);   /* ranging noise, sd 2 cm */
        shade_point(&s->g, p, &ech[i], gain, tri_noise((uint32_t)(bits >> 32)));
        if (emit_point(em, p, err))
            return -1;
    }
    return 0;
}

/* Flies one scan line of strip `strip` at along-track position `flown`. */
static int fly_line(scan *s, int strip, int source, int line, double flown, double dy,
                    wpd_error *err)
{
    const flight *f = s->fl;
    const int m = f->pulses_per_line, north = strip % 2 == 0, forward = line % 2 == 0;
    double L = s->sc->side, dt = f->line_period / m, pulse_dy = dy / m;
    ray r = {strip_centre(f, strip), 0, f->altitude, 0};
    /* Time steps j whose scan step (j or m-1-j) lands in the scene. */
    int j0 = forward ? f->lo[strip] : m - f->hi[strip];
    int j1 = forward ? f->hi[strip] : m - f->lo[strip];
    point p;
    memset(&p, 0, sizeof p);
    p.source = source;
    p.scan_dir = forward == north;   /* positive: left to right of the heading */
    echo ech[MAX_RETURNS];
    for (int j = j0; j < j1 && s->em->written < s->em->target; j++) {
        int step = forward ? j : m - 1 - j;
        double along = flown + pulse_dy * j;
        if (along > L)
            break;
        r.y = north ? along : L - along;
        r.s = f->tan_of[step];
        int n = trace_pulse(&s->tr, &s->g, &r, ech);
        if (!n)
            continue;
        s->pulses++, s->echoes += (uint64_t)n;
        p.y = r.y;
        p.gps_time = s->time + j * dt;
        p.edge = j == m - 1;
        p.angle = north ? f->rank_of[step] : -f->rank_of[step];
        if (emit_pulse(s, &p, ech, n, f->gain_of[step], err))
            return -1;
    }
    return 0;
}

/* Flies one strip; `source` is its point source id. */
static int fly_strip(scan *s, int strip, int source, wpd_error *err)
{
    double L = s->sc->side;
    uint64_t h = feature_hash(s->sc->seed, 5, source, 0, 0);
    double wobble_phase = hash_unit(h, 0), wobble_length = 500 + 400 * hash_unit(h, 1);
    uint64_t before = s->em->written;
    double flown = 0;
    for (int line = 0; flown <= L && s->em->written < s->em->target; line++) {
        double dy = next_line_spacing(s, strip, flown);
        dy *= 1 + 0.08 * sin_table(s->sc->sine, flown / wobble_length + wobble_phase);
        if (fly_line(s, strip, source, line, flown, dy, err))
            return -1;
        flown += dy;
        s->time += s->fl->line_period;
    }
    s->time += TURN_TIME;
    if (s->em->written > before)
        s->strips_used++;
    return 0;
}

/* Flies the strips (again, with new source ids, in the rare case that one
 * pass falls short) until the target count is written. */
static int fly(scan *s, wpd_error *err)
{
    const flight *f = s->fl;
    for (int pass = 0; s->em->written < s->em->target; pass++) {
        uint64_t before = s->em->written;
        for (int i = 0; i < f->strips && s->em->written < s->em->target; i++)
            if (f->inside[i] && fly_strip(s, i, (pass * f->strips + i) % 65535 + 1, err))
                return -1;
        if (s->em->written == before)    /* cannot happen: every pass sees the scene */
            return wpd_fail(err, WPD_E_INPUT, "%s: internal error: a flight pass recorded no points",
                            s->em->opt->output);
    }
    return 0;
}

/* ------------------------------------------------------------ public API */

static int check_options(const wpd_synth_options *opt, wpd_synth_options *o, wpd_error *err)
{
    *o = *opt;
    if (!o->output || !o->output[0])
        return wpd_fail(err, WPD_E_USAGE, "no output path");
    if (o->points < 1)
        return wpd_fail(err, WPD_E_USAGE, "%s: point count must be at least 1", o->output);
    if (o->tiles < 0 || o->tiles > WPD_SYNTH_MAX_TILES)
        return wpd_fail(err, WPD_E_USAGE, "%s: tile count %d is not in 1..%d", o->output,
                        o->tiles, WPD_SYNTH_MAX_TILES);
    if (o->format == WPD_FMT_NONE) {
        const char *dot = strrchr(o->output, '.');
        if (dot && !strcasecmp(dot, ".las"))
            o->format = WPD_FMT_LAS;
        else if (dot && !strcasecmp(dot, ".ply"))
            o->format = WPD_FMT_PLY;
        else
            return wpd_fail(err, WPD_E_USAGE, "%s: unknown output format (use .las or .ply)",
                            o->output);
    }
    if (o->format != WPD_FMT_LAS && o->format != WPD_FMT_PLY)
        return wpd_fail(err, WPD_E_USAGE, "%s: unknown output format", o->output);
    if (o->ply_ascii && o->format != WPD_FMT_PLY)
        return wpd_fail(err, WPD_E_USAGE, "%s: --ascii applies to PLY output only", o->output);
    return 0;
}

int wpd_synth_generate(const wpd_synth_options *options, wpd_synth_summary *summary,
                       wpd_error *err)
{
    wpd_synth_options opt;
    if (check_options(options, &opt, err))
        return -1;
    scene sc;
    scene_init(&sc, opt.seed, opt.points);
    flight fl;
    if (flight_plan(&fl, &sc, opt.points)) {
        flight_free(&fl);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", opt.output);
    }
    scene_fit_under(&sc, fl.height);
    emitter em;
    wpd_vlr vlr;
    uint8_t vlr_data[sizeof geo_keys];
    char *comments[2], cbuf[2][128];
    scan s;
    memset(&s, 0, sizeof s);
    s.sc = &sc, s.fl = &fl, s.em = &em, s.tr.sc = &sc, s.time = GPS_START;
    s.tr.ground_guess = GROUND_LEVEL;
    rng_seed(&s.g, opt.seed);
    int rc = emitter_open(&em, &opt, sc.side, err, &vlr, vlr_data, comments, cbuf);
    if (rc == 0)
        rc = fly(&s, err);
    if (rc == 0)
        rc = emitter_close(&em, err);
    emitter_abort(&em);
    flight_free(&fl);
    if (rc == 0 && summary) {
        memset(summary, 0, sizeof *summary);
        summary->points = em.written;
        summary->files = em.ntiles, summary->columns = em.columns, summary->rows = em.rows;
        summary->strips = s.strips_used;
        summary->side = sc.side;
        const double origin[3] = {ORIGIN_X, ORIGIN_Y, 0};
        for (int a = 0; a < 3; a++) {
            summary->min[a] = origin[a] + (double)em.kmin[a] * COORD_SCALE;
            summary->max[a] = origin[a] + (double)em.kmax[a] * COORD_SCALE;
        }
    }
    return rc;
}

int wpd_synth_run(const wpd_synth_options *opt, wpd_error *err)
{
    return wpd_synth_generate(opt, NULL, err);
}

/* ------------------------------------------------------------ command line */

static void usage(FILE *f)
{
    fprintf(f,
            "usage: wpd synth -n N -o OUT [--seed S] [--tiles K] [--ascii] [--force]\n"
            "\n"
            "Writes a synthetic city-like airborne LiDAR scan of exactly N points\n"
            "(terrain, streets, buildings with walls and roofs, trees with multiple\n"
            "returns, a little noise; overlapping flight strips; ~12 points/m2).\n"
            "\n"
            "  -n N         number of points (suffixes k, M, G: 10^3, 10^6, 10^9)\n"
            "  -o OUT       output file; format from the extension: .las (LAS 1.2,\n"
            "               point format 3; LAS 1.4 above 2^32-1 points) or .ply\n"
            "               (binary little-endian)\n"
            "  --seed S     random seed (default 1); same N and S give the same bytes\n"
            "  --tiles K    write K files OUT_tile1 .. OUT_tileK (1..%d), one per cell\n"
            "               of a near-square grid over the scene\n"
            "  --ascii      ascii PLY\n"
            "  --force      overwrite existing output files\n"
            "  --help       this text\n"
            "\n"
            "exit status: 0 success, 1 usage error (also: OUT exists, no --force),\n"
            "2 bad value, 3 I/O error.\n",
            WPD_SYNTH_MAX_TILES);
}

static int cli_fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prints "wpd synth: <message>" on stderr; returns code. */
static int cli_fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "wpd synth: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}

/* Parses a non-negative decimal integer with an optional k/M/G suffix. */
static int parse_count(const char *s, uint64_t *out)
{
    if (!*s || *s == '-' || *s == '+')
        return -1;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s)
        return -1;
    uint64_t mul = 1;
    if (*end == 'k' || *end == 'K')
        mul = 1000, end++;
    else if (*end == 'm' || *end == 'M')
        mul = 1000000, end++;
    else if (*end == 'g' || *end == 'G')
        mul = 1000000000, end++;
    if (*end || v > UINT64_MAX / mul)
        return -1;
    *out = v * mul;
    return 0;
}

/* Value of option argv[*i] ("--opt value" or "--opt=value"); NULL if missing. */
static const char *option_value(int argc, char **argv, int *i, const char *name)
{
    size_t n = strlen(name);
    if (argv[*i][n] == '=')
        return argv[*i] + n + 1;
    return *i + 1 < argc ? argv[++*i] : NULL;
}

static int option_is(const char *arg, const char *name)
{
    size_t n = strlen(name);
    return !strncmp(arg, name, n) && (arg[n] == '\0' || (arg[n] == '=' && name[1] == '-'));
}

/* The option with a value that arg names, or NULL. */
static const char *valued_option(const char *arg)
{
    static const char *const names[] = {"-n", "-o", "--seed", "--tiles"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (option_is(arg, names[i]))
            return names[i];
    return NULL;
}

/* Stores the value v of numeric option name. Returns 0 or an exit status. */
static int set_number(wpd_synth_options *opt, const char *name, const char *v)
{
    uint64_t num;
    if (parse_count(v, &num))
        return cli_fail(WPD_E_INPUT, "%s: bad number '%s'", name, v);
    if (!strcmp(name, "--seed")) {
        opt->seed = num;
    } else if (!strcmp(name, "-n")) {
        if (num < 1)
            return cli_fail(WPD_E_INPUT, "-n: the point count must be at least 1");
        opt->points = num;
    } else {
        if (num < 1 || num > WPD_SYNTH_MAX_TILES)
            return cli_fail(WPD_E_INPUT, "--tiles: %s is not in 1..%d", v, WPD_SYNTH_MAX_TILES);
        opt->tiles = (int)num;
    }
    return 0;
}

/* Fills *opt from the command line. Returns -1 to go on, else the exit
 * status to return (0 after --help). */
static int parse_args(int argc, char **argv, wpd_synth_options *opt)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *name, *v;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--ascii")) {
            opt->ply_ascii = 1;
        } else if (!strcmp(a, "--force")) {
            opt->overwrite = 1;
        } else if ((name = valued_option(a))) {
            if (!(v = option_value(argc, argv, &i, name)))
                return cli_fail(WPD_E_USAGE, "option %s needs a value (see 'wpd synth --help')",
                                name);
            int rc = 0;
            if (!strcmp(name, "-o"))
                opt->output = v;
            else if ((rc = set_number(opt, name, v)))
                return rc;
        } else {
            return cli_fail(WPD_E_USAGE, "unknown option '%s' (see 'wpd synth --help')", a);
        }
    }
    if (!opt->points || !opt->output)
        return cli_fail(WPD_E_USAGE, "need -n N and -o OUT (see 'wpd synth --help')");
    return -1;
}

static void print_summary(const wpd_synth_options *opt, const wpd_synth_summary *sum)
{
    char files[2200];
    if (sum->files == 1) {
        snprintf(files, sizeof files, "%s", opt->output);
    } else {
        char first[1024], last[1024];
        wpd_synth_tile_path(opt->output, 1, first, sizeof first);
        wpd_synth_tile_path(opt->output, sum->files, last, sizeof last);
        snprintf(files, sizeof files, "%d tiles (%dx%d) %s .. %s", sum->files, sum->columns,
                 sum->rows, first, last);
    }
    printf("wrote %" PRIu64 " points to %s: x %.2f .. %.2f, y %.2f .. %.2f, z %.2f .. %.2f"
           " (%.0f m scene, %d strips, seed %" PRIu64 ")\n",
           sum->points, files, sum->min[0], sum->max[0], sum->min[1], sum->max[1], sum->min[2],
           sum->max[2], sum->side, sum->strips, opt->seed);
}

int wpd_synth_main(int argc, char **argv)
{
    wpd_synth_options opt = {.seed = 1, .tiles = 1};
    int rc = parse_args(argc, argv, &opt);
    if (rc >= 0)
        return rc;
    wpd_error err;
    wpd_error_clear(&err);
    wpd_synth_options checked;
    if (check_options(&opt, &checked, &err))
        return cli_fail(WPD_E_INPUT, "%s", err.msg);
    wpd_synth_summary sum;
    if (wpd_synth_generate(&checked, &sum, &err))
        return cli_fail(err.code ? (int)err.code : WPD_E_IO, "%s", err.msg);
    print_summary(&opt, &sum);
    return 0;
}
