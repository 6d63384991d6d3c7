/* run_merge.h - the samples of a set of runs (runs.h) in gid order: a
 * k-way merge whose fan-in and buffers fit a byte budget whatever the
 * number of runs.
 *
 * Memory runs cost no buffer (views point into them), so they are merged
 * in one level whatever their number. File runs cost one chunk buffer each
 * (chunk points x WPD_RUNS_SAMPLE_BYTES); the budget also holds one
 * decoder, the output
 * buffer of one chunk and, while merging a level, one encoder:
 *   fan-in F = (budget - those) / (reader + heap entry), at least 2.
 * While the set holds more than F non-empty runs, the k smallest of them,
 * k = min(F, runs - F + 1), are merged into a new run of the set (and
 * cleared), so the last level has exactly F runs and the bytes rewritten
 * are those of the smallest runs (Huffman's rule). The gids of the set's
 * runs must be distinct (samples of one set never share a gid); two
 * samples with one gid are an error.
 */
#ifndef WPD_SPILL_RUN_MERGE_H
#define WPD_SPILL_RUN_MERGE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "spill/runs.h"

/* The merge reader's budget in the engine: 16 MB (docs/engine.md). */
#define WPD_RUN_MERGE_BUDGET ((size_t)16 << 20)

typedef struct wpd_run_merge wpd_run_merge;

/* Runs a set of file runs of chunk_points merges at once within budget. */
int wpd_run_merge_fan_in(size_t chunk_points, size_t budget);

/* A merge over every run of rs, after the levels that bring the file runs
 * down to the fan-in (they write to rs: new runs, the merged ones
 * cleared). Returns 0 with *out set, or -1 with err set. */
int wpd_run_merge_open(wpd_runs *rs, size_t budget, wpd_run_merge **out, wpd_error *err);

/* The next samples in gid order, only those with gid < end, at most one
 * chunk (wpd_runs_chunk_points) at a time: *v (v->n == 0 when none is
 * left below end), valid until the next call. Returns 0, or -1 with err. */
int wpd_run_merge_next(wpd_run_merge *m, uint64_t end, wpd_sample_view *v, wpd_error *err);

/* Samples not handed out yet. */
uint64_t wpd_run_merge_left(const wpd_run_merge *m);

/* Most samples one call hands out (the set's chunk). */
size_t wpd_run_merge_chunk_points(const wpd_run_merge *m);

/* Merge levels run at open (0: the runs were within the fan-in). */
int wpd_run_merge_levels(const wpd_run_merge *m);

/* Frees the merge (the set stays). NULL ok. */
void wpd_run_merge_close(wpd_run_merge *m);

#endif
