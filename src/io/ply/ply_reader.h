/* ply_reader.h - the state of the PLY reader, shared by its header parser
 * (ply_header.c) and its body decoder (ply_read.c). Private to those.
 */
#ifndef WPD_PLY_READER_H
#define WPD_PLY_READER_H

#include <locale.h>
#include <stdint.h>

#include "io/format.h"
#include "io/ply/ply_internal.h"
#include "io/ply/ply_stream.h"

/* One property of one element. */
typedef struct ply_prop {
    char name[WPD_DIM_NAME_MAX]; /* truncated for messages when longer */
    wpd_type type;               /* scalar type, or the item type of a list */
    wpd_type count_type;         /* list count type */
    uint8_t is_list;
    uint32_t offset;             /* vertex scalars: offset in the packed record */
} ply_prop;

typedef struct ply_elem {
    char name[WPD_DIM_NAME_MAX];
    uint64_t count;
    uint32_t first_prop, nprops;
    int has_lists;
    uint64_t item_bytes;     /* binary: bytes per item, lists counted as empty */
} ply_elem;

/* Where and how a coordinate is stored in the packed record. */
typedef struct ply_coord {
    int present;
    wpd_type type;
    uint32_t offset;
} ply_coord;

typedef struct ply_reader {
    wpd_ply_encoding enc;
    ply_elem *elems;
    uint32_t nelems, vertex;
    ply_prop *props;
    uint32_t nprops, props_cap;
    uint32_t record_size;
    uint64_t count;          /* vertices */
    uint64_t body_offset;    /* first byte after end_header */
    uint32_t header_lines;   /* lines up to and including end_header */
    uint64_t item_line;      /* ascii: line of the item read last */
    uint64_t vertex_offset;  /* binary: file offset of vertex 0 */
    int located;             /* stream positioned at vertex 0 (or fixed) */
    int fixed;               /* binary records of fixed size: direct reads */
    uint64_t next;           /* index of the next vertex to read */
    ply_coord coord[3];
    uint32_t nswap;          /* big-endian: fields to byte-swap */
    uint16_t swap_offset[WPD_MAX_DIMS];
    uint8_t swap_size[WPD_MAX_DIMS];
    ply_stream st;
    locale_t c_locale;       /* ascii: strtod_l independent of setlocale */
} ply_reader;

/* a * b + c without overflow; returns -1 on overflow. */
static inline int ply_muladd_u64(uint64_t a, uint64_t b, uint64_t c, uint64_t *out)
{
    uint64_t p;
    if (__builtin_mul_overflow(a, b, &p) || __builtin_add_overflow(p, c, out))
        return -1;
    return 0;
}

/* Reads and checks the header of r->fd into pr and r->hdr: the elements and
 * properties, the vertex element (pr->vertex, pr->count), the record schema
 * and coordinate layout, hdr.ply, and that the elements up to the vertex
 * element can fit in the file. Sets hdr.format and hdr.point_count. Does
 * not touch pr->st. Returns 0, or -1 with err set (WPD_E_INPUT naming the
 * file and, where there is one, the header line). */
int ply_read_header(wpd_reader *r, ply_reader *pr, wpd_error *err);

/* Binary vertex data that does not fit: reported as where the file ends.
 * need: bytes the vertices need; avail: bytes after offset. Returns -1. */
int ply_fail_vertex_space(const wpd_reader *r, const ply_elem *v, uint64_t need,
                          uint64_t avail, uint64_t offset, wpd_error *err);

#endif
