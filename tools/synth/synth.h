/* synth.h - `wpd synth`: a synthetic city-like airborne LiDAR scan of any
 * size, for tests and benchmarks.
 *
 * The scene (terrain, streets, buildings with walls and flat or gabled
 * roofs, street and park trees with multiple returns, a little noise) is
 * scanned by a simulated aircraft flying parallel strips with side overlap
 * (or, with `oblique`, cross strips with a wide sweep); see the comment
 * block at the top of synth.c. The points are generated and
 * written in batches, never held, so N may be anything from 1 to billions;
 * the scene grows with N so that the density stays at about 12 points/m2.
 *
 * The output is a function of (points, seed, oblique, edge_truth) only: the same options give the
 * same bytes, whatever the machine load, time or thread count. Splitting into
 * tiles only routes the same points to different files, in the same order.
 *
 * What the files hold
 *  - LAS 1.2 (1.4 above 2^32 - 1 points), point format 3, 34-byte records;
 *    scale 0.01, offset 500000 4500000 0 (the scene's south-west corner is
 *    500000 E 4500000 N); system id "wpd synth"; creation day 1 of 2025 (a
 *    fixed date, for determinism); global encoding 1 (adjusted standard GPS
 *    time); one GeoKeyDirectory VLR (EPSG:32618, metres).
 *  - PLY binary little-endian (or ascii), one "vertex" element with, packed
 *    in this order: double x y z, ushort intensity, uchar return_number,
 *    uchar number_of_returns, uchar classification, ushort point_source_id,
 *    double gps_time, uchar red green blue; two "wpd synth" comments.
 *  - With edge_truth (`--edge-truth`), one more field, edge_truth: not 0
 *    for a point within half the point spacing (the survey's pulse spacing,
 *    0.35 to 0.38 m; with --oblique that of all its strips together,
 *    about 0.3 m) of a building crease of 30 degrees or more, the kind
 *    of the nearest one: 1 roof
 *    ridge, 2 wall top (eaves, gable tops, flat roof edges), 3 wall
 *    corner, 4 wall foot (synth_creases.h); 0 elsewhere, and always on
 *    vegetation and noise.
 *    LAS: one extra byte per record (35-byte records) described by an
 *    Extra Bytes VLR (LASF_Spec/4, data_type 1 = uchar, after the
 *    projection VLR); PLY: a last property "uchar edge_truth". The points
 *    themselves are the same as without it.
 *  - Both: coordinates on the 0.01 m grid (PLY holds the same values);
 *    classification 2 ground, 5 vegetation, 6 building (roofs and walls),
 *    7 noise; return_number 1..number_of_returns (<= 5); point_source_id the
 *    flight strip (1, 2, ...); gps_time non-decreasing in file order; colour
 *    8-bit in PLY, 16-bit (8-bit * 257) in LAS. LAS only: scan_angle_rank
 *    -22..22 (-65..-35 and 35..65 with --oblique), scan_direction_flag,
 *    edge_of_flight_line; user_data 0.
 */
#ifndef WPD_SYNTH_H
#define WPD_SYNTH_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/schema.h"

/* Most tile files written at once: each holds an open file, a batch and
 * its writer's buffer (about 5 MB per tile with LAS). */
#define WPD_SYNTH_MAX_TILES 256

typedef struct wpd_synth_options {
    uint64_t points;      /* exact number of points to write, >= 1 */
    uint64_t seed;        /* scene and scan randomness; any value */
    int tiles;            /* 0 or 1: one file; K in 2..WPD_SYNTH_MAX_TILES:
                             K files, one per cell of a columns x rows grid */
    wpd_format format;    /* WPD_FMT_LAS or WPD_FMT_PLY; WPD_FMT_NONE: taken
                             from the extension of output (.las / .ply) */
    int ply_ascii;        /* PLY only: ascii instead of binary little-endian */
    int overwrite;        /* replace existing output files (else refuse) */
    int edge_truth;       /* 1: add the field edge_truth (synth_creases.h) */
    int oblique;          /* 1: the oblique survey (cross strips, 35-65 degrees;
                             synth_flight.c) instead of the default one */
    const char *output;   /* output path; tile paths are derived from it */
} wpd_synth_options;

/* What a run wrote. Bounds are those of the coordinates as stored (LAS:
 * on the 0.01 m grid; PLY stores the same values as doubles). */
typedef struct wpd_synth_summary {
    uint64_t points;      /* == options.points */
    int files;            /* 1, or the number of tiles */
    int columns, rows;    /* tile grid (1 x 1 without tiles) */
    int strips;           /* flight strips that contributed points */
    double side;          /* scene edge length in metres */
    double min[3], max[3];
} wpd_synth_summary;

/* Generates opt->points points and writes them to opt->output, or with
 * tiles = K > 1 to K files named by wpd_synth_tile_path (tile t covers
 * column (t-1) % columns, row (t-1) / columns of a near-square grid over the
 * scene, columns >= rows and columns * rows == K; every point goes to the
 * tile containing its stored x, y, so the tiles' bounds meet only at their
 * borders and their counts sum to points). Every file appears under its
 * name only when complete; on failure none of the run's files is left.
 * Returns 0 and fills *summary (if not NULL), or -1 with err set:
 * WPD_E_USAGE for bad options or an existing output without overwrite,
 * WPD_E_IO for a failure to create or write, WPD_E_MEMORY. */
int wpd_synth_generate(const wpd_synth_options *opt, wpd_synth_summary *summary,
                       wpd_error *err);

/* wpd_synth_generate without the summary. */
int wpd_synth_run(const wpd_synth_options *opt, wpd_error *err);

/* Path of tile t (1-based) of output: "city.las" -> "city_tile3.las"; the
 * suffix goes before the last extension of the file name, or at the end if
 * it has none. Returns 0, or -1 if it does not fit in len bytes. */
int wpd_synth_tile_path(const char *output, int t, char *buf, size_t len);

/* The `wpd synth` subcommand; argv[0] is "synth".
 *   wpd synth -n N -o OUT [--seed S] [--tiles K] [--edge-truth] [--oblique]
 *             [--ascii] [--force] [--help]
 * N accepts the suffixes k, M, G (10^3, 10^6, 10^9). The format comes from
 * OUT's extension (.las or .ply). On success prints one line on stdout (count,
 * files, bounds) and returns 0; on error prints one line
 * "wpd synth: <msg>" on stderr and returns 1 (usage: unknown option, missing
 * -n/-o, output exists without --force), 2 (bad value: N, seed, K,
 * extension, --ascii with LAS) or 3 (I/O: cannot create or write).
 * --help prints the usage on stdout and returns 0. */
int wpd_synth_main(int argc, char **argv);

#endif
