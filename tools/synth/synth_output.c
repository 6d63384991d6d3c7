/* synth_output.c - `wpd synth`'s output files (see synth_output.h): the
 * LAS and PLY record layouts, schemas and headers, the record encoders,
 * and the emitter that rounds, routes and batches the points over the
 * tiles and commits the files together.
 */
#include "tools/synth/synth_output.h"
#include "common/tmpdir.h"
#include "io/las/las.h"

#include <inttypes.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define ORIGIN_X 500000.0       /* georeferenced position of local (0, 0) */
#define ORIGIN_Y 4500000.0
#define COORD_SCALE 0.01        /* LAS scale; every coordinate is rounded to it */

#define BATCH_POINTS 65536      /* points per write, one file */
#define BATCH_BUDGET (1 << 20)  /* points buffered over all tiles */

/* ------------------------------------------------------------ layouts */

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

/* The ground truth of sharp features as the records' last byte. */
#define TRUTH_NAME "edge_truth"
#define TRUTH_DESCRIPTION "crease kind, half pulse spacing"

static void add_truth_field(emitter *e)
{
    wpd_schema *s = &e->hdr.schema;
    e->truth_at = (int)s->record_size;
    wpd_schema_add(s, TRUTH_NAME, WPD_U8, s->record_size);
    s->record_size++;
}

/* The Extra Bytes VLR that names the LAS record's extra byte. */
static void las_truth_vlr(emitter *e)
{
    wpd_las_info *las = &e->hdr.las;
    wpd_vlr *vlr = &e->vlr[1];
    memset(vlr, 0, sizeof *vlr);
    snprintf(vlr->user_id, sizeof vlr->user_id, "LASF_Spec");
    vlr->record_id = 4;
    vlr->length = sizeof e->ebv_data;
    snprintf(vlr->description, sizeof vlr->description, "Extra Bytes");
    wpd_las_put_descriptor(e->ebv_data, WPD_U8, TRUTH_NAME, TRUTH_DESCRIPTION);
    vlr->data = e->ebv_data;
    las->nvlr = 2;
    las->offset_to_points += 54 + (uint32_t)sizeof e->ebv_data;
    las->record_length++;
}

/* ------------------------------------------------------------ headers */

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


_Static_assert(sizeof geo_keys / sizeof *geo_keys == SYNTH_GEO_KEYS, "emitter.vlr_data size");

/* The LAS 1.2 header (1.4 above 2^32 - 1 points) with its projection VLR;
 * its pointers refer to static data and e-owned buffers. */
static void las_header(emitter *e)
{
    wpd_las_info *las = &e->hdr.las;
    wpd_vlr *vlr = &e->vlr[0];
    /* LAS 1.2 holds at most 2^32 - 1 points; beyond, 1.4 (which still
     * allows point format 3) with its 64-bit counts. An Extra Bytes VLR
     * in a 1.2 file (edge_truth) is what LAS 1.4 defines and common
     * readers accept in any version. */
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
        e->vlr_data[2 * i] = (uint8_t)(geo_keys[i] & 0xff);
        e->vlr_data[2 * i + 1] = (uint8_t)(geo_keys[i] >> 8);
    }
    vlr->data = e->vlr_data;
    las->nvlr = 1, las->vlrs = vlr;
    las->offset_to_points = las->header_size + 54 + (uint32_t)sizeof geo_keys;
    las_schema(&e->hdr.schema, las->scale, las->offset);
    e->las = 1;
    if (e->opt->edge_truth) {
        las_truth_vlr(e);
        add_truth_field(e);
    }
}

/* The PLY header with its two comments (kept in e). */
static void ply_header(emitter *e)
{
    wpd_header *h = &e->hdr;
    h->ply.encoding = e->opt->ply_ascii ? WPD_PLY_ASCII : WPD_PLY_BINARY_LE;
    snprintf(e->comment_buf[0], 128, "wpd synth: synthetic city scan, seed %" PRIu64 ", %" PRIu64
             " points", e->opt->seed, e->opt->points);
    snprintf(e->comment_buf[1], 128, "wpd synth: x y z in metres, WGS 84 / UTM zone 18N (EPSG:32618)");
    e->comments[0] = e->comment_buf[0], e->comments[1] = e->comment_buf[1];
    h->ply.comments = e->comments, h->ply.ncomments = 2;
    ply_schema(&h->schema);
    if (e->opt->edge_truth)
        add_truth_field(e);
}

/* Fills e->hdr for the output format (the writer deep-copies it). */
static void build_header(emitter *e)
{
    memset(&e->hdr, 0, sizeof e->hdr);
    e->truth_at = -1;
    e->hdr.format = e->opt->format;
    if (e->hdr.format == WPD_FMT_LAS)
        las_header(e);
    else
        ply_header(e);
}

/* ------------------------------------------------------------ records */

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

/* ------------------------------------------------------------ options */

int synth_check_options(const wpd_synth_options *opt, wpd_synth_options *o, wpd_error *err)
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

/* ------------------------------------------------------------ the emitter */

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
int synth_emit_point(emitter *e, const point *p, wpd_error *err)
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
    if (e->truth_at >= 0)
        rec[e->truth_at] = (uint8_t)p->crease;
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

void synth_emitter_abort(emitter *e)
{
    for (int i = 0; e->tiles && i < e->ntiles; i++) {
        wpd_writer_abort(e->tiles[i].w);
        wpd_batch_free(&e->tiles[i].b);
    }
    if (e->done)
        wpd_outfile_abort_all(e->done, e->ntiles);
    if (e->dir[0])
        wpd_tmpdir_untrack_outputs(e->dir);
    e->dir[0] = '\0';
    free(e->tiles);
    free(e->done);
    e->tiles = NULL;
    e->done = NULL;
}

/* Up to 256 tiles are open at once, more than the signal handlers'
 * registry holds one by one: the folder's temporary outputs of this
 * process are tracked as a whole (without a slot, the next run's sweep
 * removes them). */
static void track_folder(emitter *e)
{
    char buf[1024];
    snprintf(buf, sizeof buf, "%s", e->opt->output);
    snprintf(e->dir, sizeof e->dir, "%s", dirname(buf));
    if (wpd_tmpdir_track_outputs(e->dir))
        e->dir[0] = '\0';
}

/* Names tile i (0-based) of e, gives it a zeroed batch of cap points (so
 * that no record byte written is uninitialised) and creates its file. */
static int open_tile(emitter *e, int i, size_t cap, wpd_error *err)
{
    const wpd_synth_options *opt = e->opt;
    wpd_write_options wo = {.ply_ascii = opt->ply_ascii, .overwrite = opt->overwrite};
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
    return 0;
}

int synth_emitter_open(emitter *e, const wpd_synth_options *opt, double side, wpd_error *err)
{
    memset(e, 0, sizeof *e);
    e->opt = opt, e->side = side, e->target = opt->points;
    e->ntiles = opt->tiles > 1 ? opt->tiles : 1;
    tile_grid(e->ntiles, &e->columns, &e->rows);
    for (int a = 0; a < 3; a++)
        e->kmin[a] = INT64_MAX, e->kmax[a] = INT64_MIN;
    build_header(e);
    e->tiles = calloc((size_t)e->ntiles, sizeof *e->tiles);
    e->done = malloc((size_t)e->ntiles * sizeof *e->done);
    if (!e->tiles || !e->done)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", opt->output);
    wpd_outfile_clear_all(e->done, e->ntiles);
    track_folder(e);
    size_t cap = BATCH_BUDGET / e->ntiles;
    cap = cap > BATCH_POINTS ? BATCH_POINTS : cap < 1024 ? 1024 : cap;
    if (cap > opt->points)
        cap = (size_t)opt->points;
    for (int i = 0; i < e->ntiles; i++)
        if (open_tile(e, i, cap, err))
            return -1;
    return 0;
}

/* Flushes and finishes every tile, then renames them all: a partial set
 * is useless, and removing the tiles renamed so far would not bring back
 * the files they replaced. */
int synth_emitter_close(emitter *e, wpd_error *err)
{
    for (int i = 0; i < e->ntiles; i++)
        if (flush_tile(&e->tiles[i], err))
            return -1;
    for (int i = 0; i < e->ntiles; i++) {
        wpd_writer *w = e->tiles[i].w;
        e->tiles[i].w = NULL;
        if (wpd_writer_close_pending(w, &e->done[i], err))
            return -1;
    }
    return wpd_outfile_rename_all(e->done, e->ntiles, err);
}

void synth_emitter_bounds(const emitter *e, double min[3], double max[3])
{
    const double origin[3] = {ORIGIN_X, ORIGIN_Y, 0};
    for (int a = 0; a < 3; a++) {
        min[a] = origin[a] + (double)e->kmin[a] * COORD_SCALE;
        max[a] = origin[a] + (double)e->kmax[a] * COORD_SCALE;
    }
}
