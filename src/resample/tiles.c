/* tiles.c - the tile store of tiles.h. */
#include "resample/tiles.h"

#include <stdlib.h>
#include <string.h>

#include "common/hugepage.h"

int wpd_tiles_open_memory(wpd_tiles *t, uint64_t capacity, wpd_error *err)
{
    memset(t, 0, sizeof *t);
    t->ntiles = 1;
    size_t m = capacity ? (size_t)capacity : 1;
    t->mem.gid = wpd_malloc_large(m * sizeof *t->mem.gid);
    t->mem.xyz = wpd_malloc_large(3 * m * sizeof *t->mem.xyz);
    t->mem.halo = calloc(m, 1);
    wpd_prefer_huge_pages(t->mem.halo, m);
    t->mem_cap = (size_t)capacity;
    if (!t->mem.gid || !t->mem.xyz || !t->mem.halo) {
        wpd_tiles_close(t);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %llu points",
                        (unsigned long long)capacity);
    }
    return 0;
}

int wpd_tiles_open_spill(wpd_tiles *t, const char *base_dir, int ntiles,
                         const wpd_spill_options *opt, wpd_error *err)
{
    memset(t, 0, sizeof *t);
    t->ntiles = ntiles;
    t->spill = wpd_spill_create(base_dir, ntiles, 0, opt, err);
    return t->spill ? 0 : -1;
}

int wpd_tiles_append(wpd_tiles *t, int tile, const uint64_t *gid, const double *xyz,
                     const uint8_t *halo, size_t m, wpd_error *err)
{
    if (t->spill)
        return wpd_spill_append(t->spill, tile, gid, xyz, halo, NULL, m, err);
    wpd_tile_data *d = &t->mem;
    if (m > t->mem_cap - d->n) /* the scan counted the points: the input changed */
        return wpd_fail(err, WPD_E_INPUT, "the input changed while being read "
                        "(more points than the scan counted)");
    memcpy(d->gid + d->n, gid, m * sizeof *gid);
    memcpy(d->xyz + 3 * d->n, xyz, 3 * m * sizeof *xyz);
    memcpy(d->halo + d->n, halo, m);
    d->n += m;
    return 0;
}

int wpd_tiles_finish(wpd_tiles *t, wpd_error *err)
{
    return t->spill ? wpd_spill_finish(t->spill, err) : 0;
}

int wpd_tiles_read(const wpd_tiles *t, int tile, wpd_tile_data *d, wpd_error *err)
{
    if (t->spill)
        return wpd_spill_read(t->spill, tile, 0, d, err);
    *d = t->mem;
    return 0;
}

int wpd_tiles_chunks(const wpd_tiles *t, int tile, uint8_t **out, size_t *len,
                     wpd_error *err)
{
    if (!t->spill)
        return wpd_fail(err, WPD_E_USAGE, "internal error: chunks of a tile in memory");
    return wpd_spill_tile_chunks(t->spill, tile, out, len, err);
}

int wpd_tiles_add_chunks(wpd_tiles *t, int tile, const uint8_t *p, size_t len,
                         wpd_error *err)
{
    if (!t->spill)
        return wpd_fail(err, WPD_E_USAGE, "internal error: chunks into a tile in memory");
    return wpd_spill_add_chunks(t->spill, tile, p, len, err);
}

void wpd_tiles_release(const wpd_tiles *t, wpd_tile_data *d)
{
    if (t->spill)
        wpd_tile_data_free(d);
    else
        memset(d, 0, sizeof *d);
}

void wpd_tiles_stats(const wpd_tiles *t, wpd_spill_stats *st)
{
    memset(st, 0, sizeof *st);
    if (t->spill)
        wpd_spill_get_stats(t->spill, st);
}

void wpd_tiles_close(wpd_tiles *t)
{
    wpd_spill_destroy(t->spill);
    free(t->mem.gid);
    free(t->mem.xyz);
    free(t->mem.halo);
    memset(t, 0, sizeof *t);
}
