/* synth_output.h - `wpd synth`'s output: the points of a run, rounded to
 * the 0.01 m grid and routed to their tile, encoded as LAS point format 3
 * records or PLY vertices (see synth.h for what the files hold) and
 * written in batches. Implemented by synth_output.c.
 */
#ifndef WPD_SYNTH_OUTPUT_H
#define WPD_SYNTH_OUTPUT_H

#include <stdint.h>

#include "io/batch.h"
#include "io/writer.h"
#include "tools/synth/synth.h"

/* uint16 values of the GeoKeyDirectory (the LAS projection VLR). */
#define SYNTH_GEO_KEYS 24

/* A point with its acquisition attributes, each within its field's range. */
typedef struct point {
    double x, y, z;              /* local */
    double gps_time;
    int intensity, ret, nret, scan_dir, edge, cls, angle, source;
    int rgb[3];                  /* 8-bit */
    int crease;                  /* kind of crease it lies on (synth_creases.h): edge_truth */
} point;

/* One output file: its writer, the batch being filled, its path. */
typedef struct tile_out {
    wpd_writer *w;
    wpd_batch b;
    char path[1024];
} tile_out;

/* The run's output files. Holds the header (whose pointers refer to the
 * buffers below), so it must not move between open and close. */
typedef struct emitter {
    const wpd_synth_options *opt;
    wpd_header hdr;
    wpd_vlr vlr[2];                 /* LAS: the projection VLR and its payload, */
    uint8_t vlr_data[2 * SYNTH_GEO_KEYS];
    uint8_t ebv_data[192];          /* the Extra Bytes VLR's (with edge_truth) */
    int truth_at;                   /* record offset of edge_truth, or -1 */
    char *comments[2];              /* PLY: the header comments */
    char comment_buf[2][128];
    int las;                        /* LAS PDRF 3 records, else PLY vertices */
    tile_out *tiles;
    wpd_outfile *done;              /* [ntiles] finished, not yet renamed */
    char dir[1024];                 /* the tiles' folder, its temporary
                                       outputs tracked; "" when not */
    int ntiles, columns, rows;
    double side;
    uint64_t written, target;
    int64_t kmin[3], kmax[3];       /* bounds in 0.01 m steps */
} emitter;

/* Copies opt to *o with the format taken from the output's extension when
 * WPD_FMT_NONE, and checks it: an output path, points >= 1, tiles in
 * 0..WPD_SYNTH_MAX_TILES, LAS or PLY, ascii only with PLY. Returns 0, or
 * -1 with err set (WPD_E_USAGE). */
int synth_check_options(const wpd_synth_options *opt, wpd_synth_options *o, wpd_error *err);

/* Creates the output files of opt (checked: see synth_check_options) for
 * a scene of the given side: one, or opt->tiles on the most square grid
 * (columns >= rows). Returns 0, or -1 with err set (WPD_E_USAGE: a path
 * too long or an existing output without overwrite; WPD_E_IO; WPD_E_MEMORY);
 * call synth_emitter_abort in either case. */
int synth_emitter_open(emitter *e, const wpd_synth_options *opt, double side, wpd_error *err);

/* Rounds p (local coordinates, x and y within the scene square, z >= 0) to
 * the coordinate grid, adds it to its tile's batch and writes the batch
 * when full. At most e->target points may be emitted. Returns 0 or -1 with
 * err set. */
int synth_emit_point(emitter *e, const point *p, wpd_error *err);

/* Writes what is buffered, finishes every file under its temporary name,
 * then renames them all: they appear together or not at all (a failed
 * --force run leaves the files it would have replaced as they were).
 * Returns 0 or -1 with err set. */
int synth_emitter_close(emitter *e, wpd_error *err);

/* Discards the files not yet committed and frees e (after close too). */
void synth_emitter_abort(emitter *e);

/* Bounds of the emitted points as stored (georeferenced); at least one
 * point must have been emitted. */
void synth_emitter_bounds(const emitter *e, double min[3], double max[3]);

#endif
