/* bits.h - bit widths for packing grid coordinates into one integer key. */
#ifndef WPD_BITS_H
#define WPD_BITS_H

#include <stdint.h>

/* The fewest bits b with 2^b >= count, at most 63: enough for the indices
 * 0..count-1 of an axis with count cells (0 for count <= 1). */
static inline int wpd_bits_for(int64_t count)
{
    int b = 0;
    while (b < 63 && ((int64_t)1 << b) < count)
        b++;
    return b;
}

#endif
