/* sample_store.h - each tile's samples, in memory or in run files
 * (internal to src/resample/). */
#ifndef WPD_RESAMPLE_SAMPLE_STORE_H
#define WPD_RESAMPLE_SAMPLE_STORE_H

#include "common/error.h"
#include "resample/run.h"

/* Sizes s for n samples (edge labels when with_edge). Returns 0 or -1 (out
 * of memory; s stays valid for wpd_samples_free). */
int wpd_samples_alloc(wpd_tile_samples *s, size_t n, int with_edge);
void wpd_samples_free(wpd_tile_samples *s);


/* The sample store. A cloud resampled in memory holds
 * every tile's samples in run->store all along. A tiled run keeps them in
 * files (zstd, spill/runs.h, in their own private directory under the
 * tmpdir): a tile's samples are in run->store[t] only between
 * wpd_store_load and wpd_store_save (or wpd_store_drop), so the memory
 * they take is that of the tiles in flight, whatever n. Each save also
 * writes the tile's border - its samples within WPD_STORE_BAND halos of
 * its box's faces - which holds all a neighbour's view may ask for: the
 * Poisson view's halo (1 halo), smoothing's context (3 r <= 1.2 halos) and
 * the exact count's costs (2 halos; wpd_store_near with dist <= 2 halos).
 * The band's quarter halo more keeps a sample at the very distance asked
 * from being lost to rounding (the distance to the asking tile's box and
 * to the own box's face are computed differently). Calls for different tiles may run at once; a
 * tile must not be saved while another reads its border (colours keep
 * neighbours apart). Errors: WPD_E_IO naming the file, WPD_E_MEMORY. */
#define WPD_STORE_BAND 2.25
int wpd_store_open(wpd_run *run, wpd_error *err);       /* after the plan */
void wpd_store_close(wpd_run *run);
/* Samples of tile t, held or not; over all tiles. */
size_t wpd_store_count(const wpd_run *run, int t);
size_t wpd_run_store_count(const wpd_run *run);
/* Whether the samples carry sharp labels. */
int wpd_store_labelled(const wpd_run *run);
/* Empties every tile. */
void wpd_run_store_clear(wpd_run *run);
/* Makes run->store[t] hold tile t's samples (nothing to do when held). */
int wpd_store_load(wpd_run *run, int t, wpd_error *err);
/* Writes run->store[t] back and lets it go (in memory: nothing). Returns
 * 0 or -1; either way the arrays are no longer held. */
int wpd_store_save(wpd_run *run, int t, wpd_error *err);
/* Lets run->store[t] go unchanged (in memory: nothing). */
void wpd_store_drop(wpd_run *run, int t);
/* The end of a phase's work on tile t that returned rc: saves the samples
 * when rc is 0 (returning what the save returns), else drops them and
 * returns rc. */
int wpd_store_finish(wpd_run *run, int t, int rc, wpd_error *err);
/* Tile u's samples within dist of tile t's box (u != t, dist at most 2
 * halos), ascending by gid, into out (malloc'd). Returns 0 or -1. */
int wpd_store_near(const wpd_run *run, int t, int u, double dist, wpd_tile_samples *out,
                   wpd_error *err);

/* Samples of t's neighbours within dist of t's box (frame coordinates, at
 * their current positions), malloc'd into *out, and their sharp labels into
 * *edge (NULL when the samples carry none). Returns 0 or -1 with err set. */
int wpd_run_neighbour_samples(const wpd_run *run, int t, double dist, double **out,
                              uint8_t **edge, size_t *n, wpd_error *err);

#endif
