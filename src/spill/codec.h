/* codec.h - the coordinate codec of the spill: one chunk's points (global
 * index, x y z, halo flag) as a block of bytes, and back.
 *
 * Per chunk and axis the values are split on the coarsest decimal step
 * they lie on (the LAS scale) into grid indices, stored as differences
 * from the previous point, and small rounding residuals; values on no
 * decimal grid (PLY floats) fall back to fixed point on their binary grid,
 * values that are not finite (or -0, or too wide) to raw doubles. Global
 * indices are stored as differences, halo flags as bits. Every integer
 * column is written in the fewest bytes that hold its largest value, as
 * byte planes (planes.h), so that zstd finds the structure. Decoding is
 * bit-exact for any input doubles, NaN payloads included.
 *
 * Pure functions: no file I/O, no threads, no compression, no allocation;
 * the caller provides every array. A block is in host byte order (spill
 * files are private to one process) and carries no checksum (the zstd
 * frame around it does): the decoder checks every structural field and
 * rejects an inconsistent block, but a changed byte inside a plane of
 * values decodes to other values.
 */
#ifndef WPD_SPILL_CODEC_H
#define WPD_SPILL_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

/* Most points in one block (the count is stored in 32 bits). */
#define WPD_COORDS_MAX_POINTS UINT32_MAX

/* Bytes of the block header: no block is shorter. */
#define WPD_COORDS_HEAD_BYTES 88

/* Largest block wpd_coords_encode writes for n points (every axis raw). */
size_t wpd_coords_bound(size_t n);

/* Encodes n points: gid[n], xyz[3n] (x y z per point), halo[n] (any
 * nonzero flag is stored as 1). out: wpd_coords_bound(n) bytes. scratch:
 * 2n values, overwritten. Returns the bytes written (at least
 * WPD_COORDS_HEAD_BYTES), or 0 if n > WPD_COORDS_MAX_POINTS. Never fails
 * otherwise: any doubles encode. Deterministic: the same columns give the
 * same bytes. */
size_t wpd_coords_encode(const uint64_t *gid, const double *xyz, const uint8_t *halo, size_t n,
                         uint8_t *out, uint64_t *scratch);

/* The point count of the block of size bytes at in, after checking its
 * header and that size is exactly what the header implies. Returns 0 with
 * *n set, or -1 with err set (WPD_E_INPUT). A checked count is still not
 * bounded by size: a block of constant columns takes no bytes per point,
 * so a caller that allocates by it must apply its own limit. */
int wpd_coords_count(const uint8_t *in, size_t size, size_t *n, wpd_error *err);

/* Decodes the block of size bytes at in, which must hold exactly n points,
 * into gid[n], xyz[3n], halo[n] (0 or 1). scratch: 2n values, overwritten.
 * Reads nothing outside in[0 .. size-1] and writes nothing outside the
 * arrays, whatever the bytes. Returns 0, or -1 with err set (WPD_E_INPUT,
 * message starting "coordinate block") if the block is truncated, too
 * long, holds another count or is otherwise inconsistent; the arrays are
 * then undefined. */
int wpd_coords_decode(const uint8_t *in, size_t size, size_t n, uint64_t *gid, double *xyz,
                      uint8_t *halo, uint64_t *scratch, wpd_error *err);

#endif
