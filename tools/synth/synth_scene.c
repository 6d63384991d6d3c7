/* synth_scene.c - the layout of `wpd synth`'s city: the scene's size, the
 * block grid centred on it, the terrain waves, the height limit of the
 * buildings, and what each block holds (see synth_scene.h).
 */
#include "tools/synth/synth_scene.h"

#include <math.h>
#include <string.h>

#define DENSITY 12.0            /* points per m2 over the scene */
#define MIN_SIDE 10.0           /* smallest scene edge, metres */
#define PARK_SHARE 0.15
#define MAX_HEIGHT_SHARE 0.25   /* tallest building / flying height: < the side
                                   overlap, so strips still overlap at roof level */

void synth_scene_init(scene *sc, uint64_t seed, uint64_t points)
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

/* Keeps the buildings below MAX_HEIGHT_SHARE of the flying height: small
 * scenes are flown low, and a roof closer to the aircraft than that would
 * fall between the strips' swaths (a hole in the roof). */
void synth_scene_fit_under(scene *sc, double height)
{
    int floors = (int)((height * MAX_HEIGHT_SHARE - 1.0) / FLOOR_HEIGHT);
    sc->max_floors = floors < 1 ? 1 : floors < MAX_FLOORS ? floors : MAX_FLOORS;
    double gable = 3 * FLOOR_HEIGHT + 1.0 + MAX_GABLE_SLOPE * GABLE_MAX_SPAN / 2;
    sc->tallest = max2(sc->max_floors * FLOOR_HEIGHT + 1.0, gable);
}

const block_info *synth_block_at(const scene *sc, block_info *cache, int64_t bi, int64_t bj)
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
