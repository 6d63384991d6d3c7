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
#include "io/schema.h"

/* The LASzip VLR's identity. */
#define WPD_LAZ_VLR_USER "laszip encoded"
#define WPD_LAZ_VLR_RECORD 22204

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

#endif
