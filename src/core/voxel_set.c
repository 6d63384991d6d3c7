#include "core/voxel_set.h"

#include <stdlib.h>
#include <string.h>

#include "core/hash.h"
#include "common/hugepage.h"

int wpd_voxel_set_init(wpd_voxel_set *s, size_t cap)
{
    s->cap = cap;
    s->count = 0;
    s->slot = wpd_malloc_large(cap * sizeof *s->slot);
    if (!s->slot) {
        memset(s, 0, sizeof *s);
        return -1;
    }
    memset(s->slot, 0xff, cap * sizeof *s->slot);
    return 0;
}

static void put_raw(wpd_voxel_set *s, uint64_t key)
{
    size_t mask = s->cap - 1;
    size_t h = wpd_mix64(key) & mask;
    while (s->slot[h] != WPD_VOXEL_KEY_EMPTY) {
        if (s->slot[h] == key)
            return;
        h = (h + 1) & mask;
    }
    s->slot[h] = key;
    s->count++;
}

int wpd_voxel_set_put(wpd_voxel_set *s, uint64_t key)
{
    if (2 * (s->count + 1) > s->cap) {
        wpd_voxel_set bigger;
        if (wpd_voxel_set_init(&bigger, 2 * s->cap) < 0)
            return -1;
        for (size_t i = 0; i < s->cap; i++)
            if (s->slot[i] != WPD_VOXEL_KEY_EMPTY)
                put_raw(&bigger, s->slot[i]);
        free(s->slot);
        *s = bigger;
    }
    put_raw(s, key);
    return 0;
}

void wpd_voxel_set_free(wpd_voxel_set *s)
{
    free(s->slot);
    memset(s, 0, sizeof *s);
}
