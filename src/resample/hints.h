/* hints.h - the exact count's nearest samples, handed to smoothing through
 * tiles.
 *
 * Smoothing's cover begins by finding each input point's nearest sample
 * (method/smooth_guard.h, wpd_cover_init), and the exact count's last sweep
 * has just found it for the same points of the same tile (each point's
 * strictly nearest sample, method/eliminate.h). Through tiles the two are
 * separate phases, so every sweep keeps, per tile, a sample index a point
 * (16 bits while the tile holds fewer than 65 535 samples, else 32; a mark
 * for none) in a blob (spill/blobs.h), in the order the tile's points are
 * read back; the last sweep's stay, and the tile's smoothing reads them
 * once. A point keeps a hint only where the
 * cover's own search would find the same sample:
 *   - the sample is strictly nearer than every other sample the sweep saw
 *     (the tile's own, the neighbours' within 2 R, earlier nights'), and
 *     is one of the tile's own, so it stays where it is until the tile is
 *     smoothed;
 *   - the point lies inside the tile's box, farther from its faces than its
 *     distance to that sample plus WPD_SMOOTH_WANDER_MAX r: the neighbours
 *     of earlier colours are smoothed first, and their samples, which start
 *     outside the box, end within that of their start.
 * The sweep's deletions renumber the hints with the store (a deleted
 * sample's points lose theirs): a map per tile from the numbering the hints
 * were kept in to the store's, so the hints themselves are written once a
 * sweep. Every other point is searched for as
 * without hints, so the output does not depend on them. The hints live
 * from the exact count to the end of smoothing; their files are removed on
 * every exit path (common/tmpdir.h). Without ranks sharing the tiles every
 * tile's hints are this process's; with them, the owner of a tile runs all
 * three steps of it (ranks.h), and a rank that holds no hints for a tile
 * searches.
 */
#ifndef WPD_RESAMPLE_HINTS_H
#define WPD_RESAMPLE_HINTS_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"
#include "resample/run.h"

/* Whether this run keeps hints: tiled (the sample store in files) and
 * smoothed. */
int wpd_hints_wanted(const wpd_run *run);

/* WPD_TEST_NO_HINTS=1 in the environment (common/testhook.h): no nearest
 * samples are handed to smoothing, in memory (run->nearest) or through
 * tiles, so a test can check the output is the same without them. */
int wpd_hints_off_for_test(void);

/* WPD_TEST_CHECK_HINTS=1: smoothing also searches for every point's
 * nearest sample and fails the run where a hint named another
 * (wpd_smooth_input.check_nearest). */
int wpd_hints_checked_for_test(void);

/* Opens run->hints (two blobs a tile, the hints and their map; all
 * empty). Returns 0, or -1 with err set. */
int wpd_hints_open(wpd_run *run, wpd_error *err);

/* Removes the hints' files; run->hints becomes NULL. NULL allowed. */
void wpd_hints_close(wpd_run *run);

/* The sweep's view of tile t, as wpd_hints_keep reads it: the view's
 * samples (xyz) and, per view sample, its index in the tile's store or
 * WPD_SMOOTH_NO_NEAREST for another tile's or an earlier night's. */
typedef struct wpd_hints_view {
    const double *xyz;
    const uint32_t *store_of;
    size_t own;               /* samples in the tile's store */
} wpd_hints_view;

/* Replaces tile t's hints: pts[3i..] (i < npts, the tile's points in the
 * order wpd_tiles_read gives them) and near[i], each point's strictly
 * nearest view sample or WPD_ELIMINATE_NO_NEAREST (eliminate.h). Returns
 * 0, or -1 with err set (I/O, memory). */
int wpd_hints_keep(wpd_run *run, int t, const double *pts, const uint32_t *near, size_t npts,
                   const wpd_hints_view *v, wpd_error *err);

/* After tile t's store lost samples: moved[i] (i < n, the samples before)
 * is the new index of store sample i, or WPD_SMOOTH_NO_NEAREST for a
 * deleted one. Returns 0, or -1 with err set. */
int wpd_hints_renumber(wpd_run *run, int t, const uint32_t *moved, size_t n, wpd_error *err);

/* Drops tile t's hints (its points are searched for): where the store's
 * new numbering cannot be followed. Returns 0, or -1 with err set. */
int wpd_hints_forget(wpd_run *run, int t, wpd_error *err);

/* Tile t's hints by the slots of surface (a grid over the tile's npts
 * points as read), for wpd_smooth_input.nearest, each below samples (the
 * tile's store): *out (malloc'd; NULL when the tile has none, or they do
 * not match its points). Returns 0, or -1 with err set. */
int wpd_hints_take(const wpd_run *run, int t, const wpd_grid *surface, size_t npts,
                   size_t samples, uint32_t **out, wpd_error *err);

#endif
