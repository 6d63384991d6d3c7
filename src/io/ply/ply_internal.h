/* ply_internal.h - facts shared by the PLY reader (ply_read.c) and writer
 * (ply_write.c). Not for use outside src/io/ply/. */
#ifndef WPD_PLY_INTERNAL_H
#define WPD_PLY_INTERNAL_H

/* Records are little-endian in memory (schema.h) and both PLY modules move
 * them with plain memcpy, which is only correct on a little-endian host. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the PLY reader and writer assume a little-endian host"
#endif

/* Format keywords of the "format" header line, indexed by wpd_ply_encoding. */
#define WPD_PLY_ENCODING_NAMES {"ascii", "binary_little_endian", "binary_big_endian"}

/* Largest number of decimal digits of a vertex count (UINT64_MAX has 20):
 * the writer reserves this much room so the count can be patched in place. */
#define WPD_PLY_COUNT_DIGITS 20

#endif
