/* bits.h - bit widths for packing grid coordinates into one integer key,
 * and doubles as the bits of their representation. */
#ifndef WPD_BITS_H
#define WPD_BITS_H

#include <stdint.h>
#include <string.h>

/* The fewest bits b with 2^b >= count, at most 63: enough for the indices
 * 0..count-1 of an axis with count cells (0 for count <= 1). */
static inline int wpd_bits_for(int64_t count)
{
    int b = 0;
    while (b < 63 && ((int64_t)1 << b) < count)
        b++;
    return b;
}

/* The bits of v. For v >= 0 (including +inf) the integer order of the
 * bits is the numeric order: costs and distances are sorted, selected and
 * stored by their bits. */
static inline uint64_t wpd_double_bits(double v)
{
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

/* The double whose bits are b (wpd_double_bits' inverse). */
static inline double wpd_bits_double(uint64_t b)
{
    double v;
    memcpy(&v, &b, sizeof v);
    return v;
}

#endif
