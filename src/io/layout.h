/* layout.h - planning the output record layout when points change format.
 *
 * Same format: the output header is the input's (records pass unchanged).
 * LAS -> PLY: x y z as double (georeferenced coordinates keep their
 *   precision), every other LAS dimension as a named property (bit fields as
 *   uchar, scaled extra bytes as double), and comments that remember the LAS
 *   version, point format, scale and offset so PLY -> LAS can restore them.
 * PLY -> LAS: LAS 1.4; colour, intensity, classification and every other
 *   property with a LAS meaning go to their LAS fields (point format 6, 7 with
 *   colour, 8 with nir, or the remembered one); the rest become extra bytes
 *   described by an Extra Bytes VLR; scale and offset keep the precision of
 *   the input coordinates (see pick_scale in layout.c).
 */
#ifndef WPD_LAYOUT_H
#define WPD_LAYOUT_H

#include "io/batch.h"
#include "io/cloud.h"
#include "io/schema.h"

/* How one output field is computed from one input field. */
typedef struct wpd_field_map {
    int16_t src, dst;          /* dimension indices in the input / output schema */
    double mul;                /* value multiplier (colour depth changes), 1 otherwise */
    uint8_t raw_bytes;         /* >0: same plain type both sides, copy this many bytes */
} wpd_field_map;

typedef struct wpd_layout_map {
    int identity;              /* 1: records are copied unchanged (the output record
                                  may be longer: its tail is zeroed) */
    uint32_t nfields;
    wpd_field_map fields[WPD_MAX_DIMS];
} wpd_layout_map;

/* Output format from a file name's extension (.las, .laz, .ply, any case;
 * LAZ is compressed LAS: WPD_FMT_LAS); WPD_FMT_NONE for anything else. */
wpd_format wpd_format_from_name(const char *path);

/* 1 when path ends in .laz (any case): a LAS output written compressed. */
int wpd_format_is_laz_name(const char *path);

/* Fills out (a complete header for wpd_writer_open, owning its memory) and
 * map for writing the points of `in` as format fmt. bounds are those of the
 * finite points to be written (used to choose LAS scale and offset).
 * Returns 0, or -1 with err set. */
int wpd_layout_plan(const wpd_header *in, const wpd_bounds *bounds, wpd_format fmt,
                    wpd_header *out, wpd_layout_map *map, wpd_error *err);

/* For a PLY output planned by wpd_layout_plan: stores x y z as double
 * (other properties keep their types and order) and updates map. For
 * coordinates that no longer fit the input's type - smoothed positions of
 * float32 UTM coordinates, whose float spacing is half a metre. Returns 0,
 * or -1 with err set. */
int wpd_layout_widen_coordinates(const wpd_header *in, wpd_header *out, wpd_layout_map *map,
                                 wpd_error *err);

/* A one-byte label field `name` in the output planned by wpd_layout_plan
 * (and wpd_layout_widen_coordinates, which must come first: it maps the
 * output's fields from the input's): the output's field
 * of that name when it has one (*replaced = 1: it gets the labels, keeping
 * its place and type), else a new one after the others (LAS: an extra byte
 * described by the Extra Bytes VLR, see wpd_las_append_extra, with the
 * given description; PLY: a uchar property). Returns its index in
 * out->schema, or -1 with err set (no room: the record, the VLR or the
 * schema is full; WPD_E_MEMORY). */
int wpd_layout_add_label(wpd_header *out, const char *name, const char *description,
                         int *replaced, wpd_error *err);

/* Stores value[i] into dimension d of record i of b, for i < b->n. */
void wpd_layout_set_labels(const wpd_dim *d, wpd_batch *b, const uint8_t *value);

/* Converts src (input layout) into dst (output layout, capacity >= src->n):
 * every mapped field converted, unmapped output fields zero, xyz copied. */
void wpd_layout_apply(const wpd_layout_map *map, const wpd_schema *in,
                      const wpd_schema *out, const wpd_batch *src, wpd_batch *dst);

#endif
