/* schema.h - the layout of one point record and the header facts of a file.
 *
 * Every reader delivers points as fixed-size records in a canonical layout:
 * little-endian, fields at the byte offsets given by the schema. For LAS the
 * record is exactly the file's point record; for PLY it is the binary
 * little-endian vertex record (big-endian and ascii files are converted on
 * the fly). Alongside each record the reader delivers decoded double x, y, z.
 */
#ifndef WPD_SCHEMA_H
#define WPD_SCHEMA_H

#include <stddef.h>
#include <stdint.h>

#include "common/warnings.h"

typedef enum wpd_type {
    WPD_I8, WPD_U8, WPD_I16, WPD_U16, WPD_I32, WPD_U32,
    WPD_I64, WPD_U64, WPD_F32, WPD_F64
} wpd_type;

typedef enum wpd_format { WPD_FMT_NONE = 0, WPD_FMT_LAS, WPD_FMT_PLY } wpd_format;

#define WPD_DIM_NAME_MAX 48
#define WPD_MAX_DIMS 256

/* One named dimension of a record. A bit field (LAS return number, flags)
 * is stored in an integer field: value = (field >> bit_shift) & mask(bit_count).
 * A scaled dimension (LAS X/Y/Z, scaled extra bytes) reads as raw*scale+add. */
typedef struct wpd_dim {
    char name[WPD_DIM_NAME_MAX];
    wpd_type type;      /* storage type of the field */
    uint32_t offset;    /* byte offset within the record */
    uint8_t bit_shift;  /* first bit of a bit field */
    uint8_t bit_count;  /* 0: the whole field; else width of the bit field */
    uint8_t scaled;     /* 1: value = raw * scale + add */
    double scale, add;
} wpd_dim;

typedef struct wpd_schema {
    uint32_t record_size;         /* bytes per record */
    uint32_t ndims;
    int dim_x, dim_y, dim_z;      /* indices of the coordinates, -1 if absent */
    wpd_dim dims[WPD_MAX_DIMS];
} wpd_schema;

/* ---- LAS header facts ---- */
/* user_id and description hold every byte of their fixed-width fields, also
 * those after a terminating NUL (some writers leave garbage there), plus a
 * final NUL: read as C strings they give the text up to the first NUL (used
 * for matching, e.g. "LASF_Spec"), and the LAS writer writes all 16 and 32
 * bytes back. Code that builds a VLR must zero the struct first. */
typedef struct wpd_vlr {
    uint16_t reserved;
    char user_id[17];             /* the 16-byte field + NUL */
    uint16_t record_id;
    uint64_t length;              /* payload bytes */
    char description[33];         /* the 32-byte field + NUL */
    uint8_t *data;                /* payload (owned), length bytes */
} wpd_vlr;

/* LAZ (compressed LAS): the LASzip VLR ("laszip encoded", record 22204),
 * which the reader takes out of the VLR list (the records it delivers are
 * decompressed), and what the chunk table gave. */
#define WPD_LAZ_MAX_ITEMS 8
typedef struct wpd_laz_item {
    uint16_t type, size, version;
} wpd_laz_item;

typedef struct wpd_laz_info {
    int compressed;               /* 1 for a LAZ file */
    uint16_t compressor, coder;   /* compressor 1 point-wise, 2 point-wise
                                     chunked, 3 layered chunked */
    uint8_t version_major, version_minor;
    uint16_t version_revision;
    uint32_t options, chunk_size; /* chunk_size 0xFFFFFFFF: variable chunks */
    uint16_t nitems;
    wpd_laz_item items[WPD_LAZ_MAX_ITEMS];
    uint64_t chunks;              /* chunks in the chunk table, 0 if none read */
    int wpd_vlr;                  /* 1: the VLR's description is the one wpd's
                                     writer gives it (WPD_LAZ_VLR_DESCRIPTION) */
} wpd_laz_info;

typedef struct wpd_las_info {
    uint8_t version_major, version_minor;
    uint8_t pdrf;                 /* point data record format 0..10 */
    uint16_t record_length;       /* bytes per point record */
    uint16_t extra_bytes;         /* record_length minus the PDRF's standard size */
    uint16_t header_size;
    uint32_t offset_to_points;
    uint16_t file_source_id, global_encoding;
    uint8_t guid[16];
    char system_id[33], software[33]; /* the 32-byte fields + NUL, every byte as
                                         read (system_id is written back so) */
    uint16_t creation_day, creation_year;
    double scale[3], offset[3];
    double min[3], max[3];        /* as stored in the header */
    uint64_t point_count;         /* 64-bit count where the file has one */
    uint64_t points_by_return[15];
    uint64_t waveform_start;      /* 1.3+: start of waveform data packet record */
    uint32_t nvlr, nevlr;
    wpd_vlr *vlrs, *evlrs;        /* owned arrays */
    uint8_t *header_tail;         /* bytes past the standard header (owned) */
    uint32_t header_tail_len;
    uint8_t *vlr_tail;            /* bytes between the last VLR and the point
                                     data (owned; LAS 1.0: the start signature) */
    uint32_t vlr_tail_len;
    wpd_laz_info laz;             /* compressed files only (laz.compressed) */
    int copc;                     /* 1: a COPC file; its info VLR and hierarchy
                                     EVLR were dropped from vlrs and evlrs */
} wpd_las_info;

/* ---- PLY header facts ---- */
typedef enum wpd_ply_encoding { WPD_PLY_ASCII, WPD_PLY_BINARY_LE, WPD_PLY_BINARY_BE } wpd_ply_encoding;

typedef struct wpd_ply_element_info {
    char name[WPD_DIM_NAME_MAX];
    uint64_t count;
    uint32_t nprops;
    int has_lists;
} wpd_ply_element_info;

typedef struct wpd_ply_info {
    wpd_ply_encoding encoding;
    uint32_t ncomments, nobj_info, nelements;
    char **comments;              /* owned, without the "comment " keyword */
    char **obj_info;              /* owned */
    wpd_ply_element_info *elements; /* owned, in file order */
    uint32_t vertex_element;      /* index of "vertex" in elements */
} wpd_ply_info;

/* Everything known about a file from its header. */
typedef struct wpd_header {
    wpd_format format;
    char path[1024];
    uint64_t file_size;
    uint64_t point_count;         /* records in the file (PLY: incl. non-finite) */
    wpd_schema schema;
    wpd_las_info las;             /* valid when format == WPD_FMT_LAS */
    wpd_ply_info ply;             /* valid when format == WPD_FMT_PLY */
    wpd_warnings warnings;        /* what the reader read despite the specification */
} wpd_header;

/* Size in bytes of a value of type t. */
size_t wpd_type_size(wpd_type t);
/* PLY name of t (char, uchar, short, ushort, int, uint, float, double;
 * int64/uint64 for the 64-bit types). */
const char *wpd_type_name(wpd_type t);
/* Parses a PLY type name in either style (uchar or uint8 ...). Returns 0 and
 * sets *t, or -1 if the name is unknown. */
int wpd_type_parse(const char *name, wpd_type *t);

/* Appends a dimension; returns its index, or -1 when the schema is full or
 * the name is too long. Does not change record_size. */
int wpd_schema_add(wpd_schema *s, const char *name, wpd_type type, uint32_t offset);
/* Index of the dimension called name, or -1. */
int wpd_schema_find(const wpd_schema *s, const char *name);

/* 1 for the integer types, 0 for float and double. */
static inline int wpd_type_is_int(wpd_type t) { return t != WPD_F32 && t != WPD_F64; }

/* Raw little-endian integer field of type t at p (integer types only; 0 for
 * the float types), widened to 64 bits: a U64 above INT64_MAX comes back as
 * its two's-complement bit pattern. The one decoder of integer fields by
 * type; inline because it sits in the coordinate decode loops. memcpy keeps
 * unaligned access legal. */
static inline int64_t wpd_value_get_int(wpd_type t, const uint8_t *p)
{
    switch (t) {
    case WPD_I8: return (int8_t)p[0];
    case WPD_U8: return p[0];
    case WPD_I16: { int16_t v; __builtin_memcpy(&v, p, 2); return v; }
    case WPD_U16: { uint16_t v; __builtin_memcpy(&v, p, 2); return v; }
    case WPD_I32: { int32_t v; __builtin_memcpy(&v, p, 4); return v; }
    case WPD_U32: { uint32_t v; __builtin_memcpy(&v, p, 4); return v; }
    case WPD_I64: case WPD_U64: { int64_t v; __builtin_memcpy(&v, p, 8); return v; }
    default: return 0;
    }
}

/* Raw little-endian value of type t at p as a double (no bit field, no
 * scale). Inline: it sits in the coordinate decode loops of the readers. */
static inline double wpd_value_get(wpd_type t, const uint8_t *p)
{
    switch (t) {
    case WPD_U64: return (double)(uint64_t)wpd_value_get_int(t, p);
    case WPD_F32: { float v; __builtin_memcpy(&v, p, 4); return v; }
    case WPD_F64: { double v; __builtin_memcpy(&v, p, 8); return v; }
    default: return (double)wpd_value_get_int(t, p);
    }
}

/* Reads dimension d of one record as a double (bit field, scale applied). */
double wpd_dim_get(const wpd_dim *d, const uint8_t *record);
/* Stores v into dimension d of one record: rounds for integer types, clamps
 * to the type's range, inverts the scale, updates only the bit field's bits. */
void wpd_dim_set(const wpd_dim *d, uint8_t *record, double v);

/* Releases what the header owns (VLR payloads, comments ...) and zeroes it. */
void wpd_header_free(wpd_header *h);
/* Deep copy of src into dst (dst must not own anything). Returns 0, or -1 if
 * out of memory. */
int wpd_header_copy(wpd_header *dst, const wpd_header *src);

#endif
