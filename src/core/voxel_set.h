/* voxel_set.h - a growable open-addressing set of 64-bit voxel keys, for
 * counting occupied voxels (radius estimate, out-of-core scan). */
#ifndef WPD_CORE_VOXEL_SET_H
#define WPD_CORE_VOXEL_SET_H

#include <stddef.h>
#include <stdint.h>

#define WPD_VOXEL_KEY_EMPTY UINT64_MAX

typedef struct wpd_voxel_set {
    uint64_t *slot;          /* cap slots, WPD_VOXEL_KEY_EMPTY when free */
    size_t cap, count;
} wpd_voxel_set;

/* Empty set with cap slots (a power of two). Returns 0, or -1 when out of
 * memory (the set is then zeroed). */
int wpd_voxel_set_init(wpd_voxel_set *s, size_t cap);

/* Adds key (not WPD_VOXEL_KEY_EMPTY), doubling the table at half load.
 * Returns 0, or -1 when out of memory (the set is unchanged). */
int wpd_voxel_set_put(wpd_voxel_set *s, uint64_t key);

/* Frees the table and zeroes the set. */
void wpd_voxel_set_free(wpd_voxel_set *s);

#endif
