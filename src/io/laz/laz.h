/* laz.h - LAZ (compressed LAS) reading: the LASzip VLR, the chunk table
 * and the point-wise compressor (point formats 0-5), behind the reader
 * interface of reader.h. las_read.c parses the LAS header and VLRs and
 * hands compressed files over here. Not for use outside src/io, except
 * the names for `wpd info`.
 */
#ifndef WPD_LAZ_H
#define WPD_LAZ_H

#include <stdint.h>

#include "common/error.h"
#include "common/outfile.h"
#include "io/schema.h"

/* The LASzip VLR's identity. */
#define WPD_LAZ_VLR_USER "laszip encoded"
#define WPD_LAZ_VLR_RECORD 22204
/* How the description of the LASzip VLR wpd writes starts (the compressor's
 * name follows in brackets): with the generating software, it tells LAZ
 * written by wpd from LAZ that another program made of wpd's LAS. */
#define WPD_LAZ_VLR_DESCRIPTION "wpd LAZ"

/* Name of LASzip item type t ("POINT10", ...; "unknown" for others). */
const char *wpd_laz_item_name(uint16_t type);
/* Name of compressor c ("point-wise chunked", ...). */
const char *wpd_laz_compressor_name(uint16_t c);

/* Parses the payload (len bytes) of a LASzip VLR of file path into *info
 * (info->compressed is set by the caller). Returns 0, or -1 with err set
 * (WPD_E_INPUT, one line naming path) if the payload is too short for its
 * item list or lists more than WPD_LAZ_MAX_ITEMS items. */
int wpd_laz_parse_vlr(const char *path, const uint8_t *data, uint64_t len, wpd_laz_info *info,
                      wpd_error *err);

/* Checks h->las.laz against the header (point format with the compression
 * bits cleared, record length) and refuses, with one line naming the file,
 * what this reader does not decode: the layered compressor (point formats
 * 6-10), LASzip 1.x items (version 1), waveform packets, unknown coders,
 * compressors, item types or versions. Returns 0 or -1 (WPD_E_INPUT). */
int wpd_laz_check(const wpd_header *h, wpd_error *err);

/* ---- writing (laz_write.c): the point-wise chunked compressor ---- */

/* Points per chunk of the LAZ files wpd writes (LASzip's default). */
#define WPD_LAZ_CHUNK_POINTS 50000u

/* The points per chunk the writer uses: WPD_LAZ_CHUNK_POINTS, or for the
 * tests that compare wpd's LAZ with LASzip's at other chunk sizes, the
 * environment's WPD_TEST_LAZ_CHUNK (common/testhook.h). Every process of
 * one output must see the same value (the ranks' parts are whole chunks). */
uint32_t wpd_laz_chunk_points(void);

/* Compresses the point records of a LAS writer. The LAS writer does the
 * header, the VLRs (adding the one of wpd_laz_writer_vlr) and the EVLRs;
 * this writes what lies between: the chunk table offset, the chunks and
 * the chunk table. */
typedef struct wpd_laz_writer wpd_laz_writer;

/* For records of point format pdrf, record_length bytes (>= the format's
 * size; the rest are extra bytes). path names the output in messages and
 * must outlive the writer. Returns NULL with err set: WPD_E_USAGE (one
 * line) for point formats 4, 5, 9 and 10 (waveform packets), which are not
 * compressed; WPD_E_MEMORY. Formats 6-8 use the layered compressor. */
wpd_laz_writer *wpd_laz_writer_create(const char *path, uint8_t pdrf, uint16_t record_length,
                                      wpd_error *err);
void wpd_laz_writer_free(wpd_laz_writer *z);

/* The LASzip VLR describing the items, for the output's VLR list: *v
 * points into z (valid while z lives; v->data must not be freed). */
void wpd_laz_writer_vlr(const wpd_laz_writer *z, wpd_vlr *v);

/* Writes the start of the point data (the placeholder of the chunk table
 * offset) at f's position, which must be the header's offset to points. */
int wpd_laz_writer_begin(wpd_laz_writer *z, wpd_outfile *f, wpd_error *err);

/* Compresses n records (rec, record_length bytes each), writing each chunk
 * to f as it fills. Returns 0, or -1 with err set. */
int wpd_laz_writer_put(wpd_laz_writer *z, wpd_outfile *f, const uint8_t *rec, size_t n,
                       wpd_error *err);

/* Writes the last chunk and the chunk table, and patches the table's
 * offset at points_start (the header's offset to points). *end gets the
 * file offset after the table, where EVLRs may follow. Returns 0, or -1
 * with err set. */
int wpd_laz_writer_finish(wpd_laz_writer *z, wpd_outfile *f, uint64_t points_start,
                          uint64_t *end, wpd_error *err);

/* One output written by several processes (writer.h): closes the open
 * chunk and gives the sizes of z's chunks (*sizes points into z), or
 * appends the chunks another process wrote after z's (sizes: n of them,
 * bytes in all) to z's table. Return 0, or -1 with err set. */
int wpd_laz_writer_end_part(wpd_laz_writer *z, wpd_outfile *f, uint64_t *nchunks,
                            const uint32_t **sizes, wpd_error *err);
int wpd_laz_writer_add_chunks(wpd_laz_writer *z, const uint32_t *sizes, uint64_t n,
                              uint64_t bytes, wpd_error *err);

#endif
