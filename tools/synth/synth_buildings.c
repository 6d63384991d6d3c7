/* synth_buildings.c - the buildings of `wpd synth`'s city: one box
 * building per lot of a built block, its footprint, height and roof drawn
 * from the feature hash of its lot (see synth_scene.h).
 */
#include "tools/synth/synth_scene.h"

#include <stddef.h>

#define LOT_SETBACK 3.0

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
const building *synth_building_at(const scene *sc, double x, double y, block_info *blocks,
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
    const block_info *blk = synth_block_at(sc, blocks, p.bi, p.bj);
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
