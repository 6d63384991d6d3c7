/* tiles.h - where the tiles' points live between the tile pass and the
 * passes over tiles: zstd spill files (tiled runs), or one tile held in
 * memory (a cloud that fits the budget). The phases read tiles through
 * this and never know which. */
#ifndef WPD_TILES_H
#define WPD_TILES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "spill/spill.h"

typedef struct wpd_tiles {
    int ntiles;
    wpd_spill *spill;         /* tiled runs */
    wpd_tile_data mem;        /* the one tile of an in-memory run */
    size_t mem_cap;
} wpd_tiles;

/* One tile in memory with room for capacity points. Returns 0 or -1. */
int wpd_tiles_open_memory(wpd_tiles *t, uint64_t capacity, wpd_error *err);
/* ntiles spill files under base_dir (opt as wpd_spill_create). */
int wpd_tiles_open_spill(wpd_tiles *t, const char *base_dir, int ntiles,
                         const wpd_spill_options *opt, wpd_error *err);

/* Appends m points (global index, frame coordinates, halo flag) to tile t,
 * in the order they come. Not thread-safe: the tiler appends in turn. */
int wpd_tiles_append(wpd_tiles *t, int tile, const uint64_t *gid, const double *xyz,
                     const uint8_t *halo, size_t m, wpd_error *err);
/* After the last append. */
int wpd_tiles_finish(wpd_tiles *t, wpd_error *err);

/* Tile `tile`'s points into *d (records never). In memory the arrays are
 * the store's own (*d must then not be changed); release with
 * wpd_tiles_release either way. Thread-safe. */
int wpd_tiles_read(const wpd_tiles *t, int tile, wpd_tile_data *d, wpd_error *err);
void wpd_tiles_release(const wpd_tiles *t, wpd_tile_data *d);

/* A spilled tile's compressed chunks out of one tiles' spill (finished)
 * and into another's (wpd_spill_tile_chunks, wpd_spill_add_chunks). Return
 * 0 or -1 (err set; WPD_E_USAGE for tiles in memory). */
int wpd_tiles_chunks(const wpd_tiles *t, int tile, uint8_t **out, size_t *len,
                     wpd_error *err);
int wpd_tiles_add_chunks(wpd_tiles *t, int tile, const uint8_t *p, size_t len,
                         wpd_error *err);

/* Spill statistics (zeros in memory). */
void wpd_tiles_stats(const wpd_tiles *t, wpd_spill_stats *st);

/* Frees the memory tile or removes the spill files. */
void wpd_tiles_close(wpd_tiles *t);

#endif
