/* planes.h - byte planes: byte b of every value (or record) stored together.
 *
 * A value of w bytes becomes w planes of n bytes (plane b holds byte b of
 * every value). Narrow planes of small integers are mostly zero and
 * compress to nearly nothing, and the noisy low bytes stay apart from them;
 * records transposed this way put each field's bytes next to the same
 * bytes of the neighbours' field. Pure functions: no allocation, no I/O,
 * no shared state; safe from any thread. Source and destination must not
 * overlap.
 */
#ifndef WPD_SPILL_PLANES_H
#define WPD_SPILL_PLANES_H

#include <stddef.h>
#include <stdint.h>

/* Bytes needed for the unsigned value m, rounded up to a plane width the
 * codec stores: 0 (m == 0), 1, 2, 4 or 8. */
unsigned wpd_plane_width(uint64_t m);

/* Writes the low w bytes (w <= 8) of v[0..n-1] as w planes into dst
 * (w * n bytes; plane b at dst + b * n). */
void wpd_planes_put(uint8_t *restrict dst, const uint64_t *restrict v, size_t n, unsigned w);

/* Inverse of wpd_planes_put: reads w * n bytes at src into v[0..n-1], the
 * high 8 - w bytes of every value 0 (w == 0: all values 0). */
void wpd_planes_get(uint64_t *restrict v, const uint8_t *restrict src, size_t n, unsigned w);

/* n records of w bytes each (n * w bytes at rec, row-major) into w planes
 * of n bytes at dst. */
void wpd_planes_from_records(uint8_t *restrict dst, const uint8_t *restrict rec, size_t n,
                             size_t w);

/* Inverse of wpd_planes_from_records: w planes of n bytes into n records. */
void wpd_planes_to_records(uint8_t *restrict rec, const uint8_t *restrict planes, size_t n,
                           size_t w);

#endif
