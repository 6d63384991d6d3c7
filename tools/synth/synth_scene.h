/* synth_scene.h - the model of `wpd synth`'s city (see the scene in
 * synth.c's overview): its size and block grid, the terrain, what each
 * block holds, the buildings on its lots and the trees along its streets
 * and in its parks, and the surface materials a pulse can return from.
 *
 * Every feature is a pure function of (seed, its cell), computed on demand
 * by the lookups below; nothing is stored per feature. The lookups keep a
 * one-entry cache each, owned by the caller (consecutive pulses nearly
 * always hit the same block, lot and tree), so the scene itself is
 * read-only once set up and the lookups need no global state.
 *
 * Implemented by synth_scene.c (layout, terrain, blocks), synth_buildings.c
 * and synth_trees.c.
 */
#ifndef WPD_SYNTH_SCENE_H
#define WPD_SYNTH_SCENE_H

#include <stdint.h>

#include "tools/synth/synth_math.h"

#define GROUND_LEVEL 120.0      /* mean terrain elevation */

#define BLOCK_PERIOD 96.0       /* street + block */
#define STREET_WIDTH 16.0
#define FLOOR_HEIGHT 3.1
#define MAX_FLOORS 20
#define GABLE_MAX_SPAN 20.0     /* widest building with a gabled roof */
#define MAX_GABLE_SLOPE 0.85    /* rise per metre */

#define KERB_OFFSET 2.5         /* street tree line distance from the block edge */
#define TREE_MAX_REACH 4.6      /* largest crown radius incl. lobes */

/* What a return hit; indexes the class, intensity and colour tables of
 * synth_scan.c. */
enum material { MAT_GROUND, MAT_STREET, MAT_ROOF, MAT_WALL, MAT_TREE, MAT_NOISE, MAT_COUNT };

/* ------------------------------------------------------------ layout, terrain */

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

/* Sets up the scene of a run of `points` points: its side (about 12 points
 * per m2, at least 10 m), the block grid centred on it, the terrain waves
 * from the seed, buildings of up to MAX_FLOORS. */
void synth_scene_init(scene *sc, uint64_t seed, uint64_t points);

/* Keeps the buildings below a quarter of the flying height `height` (a
 * roof closer to a low aircraft would fall between the strips' swaths);
 * sets max_floors and tallest. Call once, after synth_scene_init. */
void synth_scene_fit_under(scene *sc, double height);

/* Terrain elevation at local (x, y): GROUND_LEVEL plus the four waves.
 * Inline: it is evaluated for every pulse. */
static inline double terrain(const scene *sc, double x, double y)
{
    double z = GROUND_LEVEL;
    for (int i = 0; i < NWAVES; i++)
        z += sc->wave_amp[i] * sin_table(sc->sine, sc->wave_kx[i] * x + sc->wave_ky[i] * y +
                                                      sc->wave_phase[i]);
    return z;
}

/* Where a local position falls in the block grid. */
typedef struct block_pos {
    int64_t bi, bj;              /* block indices */
    double u, v;                 /* position within the block period, [0, BLOCK_PERIOD) */
} block_pos;

/* The block of local (x, y) and the position within its period; x and y
 * must be above -2 blocks (scene.grid0), which every ray position is. */
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

/* 1 if p lies in a street: the strip along each block's low x and y edges. */
static inline int in_street(const block_pos *p) { return p->u < STREET_WIDTH || p->v < STREET_WIDTH; }

/* ------------------------------------------------------------ blocks */

/* What a block holds. Kept in a one-entry cache per kind of lookup:
 * consecutive pulses nearly always fall in the same block. */
typedef struct block_info {
    int64_t bi, bj;
    int valid;
    int park;                    /* no buildings, trees on a grid */
    int nx, ny;                  /* lots across x and y */
} block_info;

/* What block (bi, bj) holds (park or built, lots across x and y), through
 * the one-entry cache; the central block is never a park. */
const block_info *synth_block_at(const scene *sc, block_info *cache, int64_t bi, int64_t bj);

/* ------------------------------------------------------------ buildings */

enum roof_kind { ROOF_FLAT, ROOF_RIDGE_X, ROOF_RIDGE_Y };

typedef struct building {
    int64_t bi, bj; int li, lj;  /* identity, for the cache */
    int valid;                   /* cache slot filled */
    double lx0, lx1, ly0, ly1;   /* the lot */
    double x0, x1, y0, y1;       /* footprint */
    double zb, ze;               /* base, eaves (flat roof height) */
    double slope;                /* gable rise per metre from the eaves */
    int roof;                    /* enum roof_kind */
    double shade;                /* roof colour/intensity factor */
} building;

/* The building standing on the lot at (x, y), or NULL (street, park);
 * *street says whether (x, y) lies in a street. blocks and cache are the
 * caller's one-entry caches of the block and building looked up last; the
 * result points into cache. */
const building *synth_building_at(const scene *sc, double x, double y, block_info *blocks,
                                  building *cache, int *street);

/* ------------------------------------------------------------ trees */

typedef struct tree {
    int64_t key[4];              /* identity, for the cache */
    int valid, present;
    double cx, cy, zc;           /* crown centre */
    double rh, rv;               /* crown radii */
    double lobe, rot_c, rot_s;   /* outline: r * (1 + lobe * cos 3(phi - rot)) */
} tree;

/* The tree whose crown may cover (x, y): the nearest of the park tree of
 * the cell and the street trees of the two kerb directions that can reach
 * it, or NULL. caches[0..2] are per kind (two kerb directions, park) and
 * blocks the block cache; the result points into caches. */
const tree *synth_tree_at(const scene *sc, double x, double y, block_info *blocks,
                          tree caches[3]);

#endif
