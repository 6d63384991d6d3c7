/* synth.c - a synthetic city-like airborne LiDAR scan (see synth.h): the
 * public API, which sets up the scene, the flight and the output and runs
 * the scan. This comment describes the whole generator; its parts are
 *   synth_math.h        hashing, the random stream, fast math
 *   synth_scene.[ch]    scene size, block grid, terrain, blocks
 *   synth_buildings.c   buildings on the lots
 *   synth_trees.c       street and park trees
 *   synth_trace.[ch]    a pulse through the scene: its echoes, noise
 *   synth_flight.[ch]   the flight plan: strips, height, mirror sweep
 *   synth_scan.[ch]     flying the lines; attributes of each echo
 *   synth_output.[ch]   options check, LAS/PLY records, tiles, files
 *   synth_cli.c         the `wpd synth` command line
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
 *  - The oblique survey (--oblique; synth_flight.c): the same scene flown
 *    at the same height in strips north/south and then east/west (the
 *    tracer swaps x and y for the latter), pulses leaning 35..65 deg to
 *    either side (none nearer nadir: the ground is seen from the
 *    neighbouring strips), strips a quarter swath apart whose tracks reach
 *    a quarter swath beyond the scene: every wall faces strips that see it
 *    at a steep angle. A steep
 *    ray may pass over a lot between the ground and roof levels: the
 *    tracer looks for buildings every 10 m of its run.
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
#include "tools/synth/synth.h"

#include "tools/synth/synth.h"

#include <string.h>

#include "tools/synth/synth_flight.h"
#include "tools/synth/synth_output.h"
#include "tools/synth/synth_scan.h"
#include "tools/synth/synth_scene.h"

/* What the run wrote, for the caller. */
static void summarise(const emitter *em, const scan *s, const scene *sc, wpd_synth_summary *sum)
{
    memset(sum, 0, sizeof *sum);
    sum->points = em->written;
    sum->files = em->ntiles, sum->columns = em->columns, sum->rows = em->rows;
    sum->strips = s->strips_used;
    sum->side = sc->side;
    synth_emitter_bounds(em, sum->min, sum->max);
}

int wpd_synth_generate(const wpd_synth_options *options, wpd_synth_summary *summary,
                       wpd_error *err)
{
    wpd_synth_options opt;
    if (synth_check_options(options, &opt, err))
        return -1;
    scene sc;
    synth_scene_init(&sc, opt.seed, opt.points);
    flight fl;
    if (synth_flight_plan(&fl, &sc, opt.points, opt.oblique)) {
        synth_flight_free(&fl);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", opt.output);
    }
    synth_scene_fit_under(&sc, fl.height);
    emitter em;
    scan s;
    synth_scan_init(&s, &sc, &fl, &em, opt.seed, opt.edge_truth);
    int rc = synth_emitter_open(&em, &opt, sc.side, err);
    if (rc == 0)
        rc = synth_fly(&s, err);
    if (rc == 0)
        rc = synth_emitter_close(&em, err);
    synth_emitter_abort(&em);
    synth_flight_free(&fl);
    if (rc == 0 && summary)
        summarise(&em, &s, &sc, summary);
    return rc;
}

int wpd_synth_run(const wpd_synth_options *opt, wpd_error *err)
{
    return wpd_synth_generate(opt, NULL, err);
}
