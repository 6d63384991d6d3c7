/* pass.h - one streaming pass over the inputs on several threads: the
 * scan's counting, the tiler and the records pass all read through it.
 *
 * Reading. Where every file can seek (LAS, binary PLY without lists), each
 * lane reads with a cloud of its own (wpd_cloud_reopen): lanes take units
 * of records in turn (a batch's capacity, WPD_BATCH_POINTS records unless
 * they are large; never across a file boundary), seek to them and read
 * them in parallel. Elsewhere (ASCII PLY), and with one lane, reading is
 * serial: lanes take the next batch from one shared cloud under a lock and
 * process it while the others read.
 *
 * Global indices (the index of a point among the finite points of all
 * files, in file order) of a batch are known when it is read serially, or
 * when the caller knows that no record is dropped (every_record_finite:
 * then global index = record index). Otherwise - parallel reading of a
 * cloud with non-finite points - a unit's first global index depends on the
 * units before it, and only the commit of an ordered pass knows it.
 *
 * Contract:
 * - the batch (wpd_pass_batch.batch) is owned by the pass and belongs to
 *   one lane: callbacks read it but keep no pointer into it; it is valid
 *   from the lane call through the commit.
 * - lane: called on up to `threads` threads at once, each batch once; it
 *   works on pb->lane's state of the caller (no locking needed there) and
 *   on shared state only thread-safely.
 * - commit (ordered passes): called for every non-empty batch in reading
 *   order (global-index order), one call at a time, by the thread that
 *   made that batch's lane call, after it; may touch shared state without
 *   locks. pb->first_gid is always exact here.
 * - a callback returns 0, or -1 with err set: the pass stops taking work
 *   and wpd_pass_run returns the first failure (first_error.h); no commit
 *   is made after a failure.
 * - determinism: which lane sees which batch, and where a batch is cut,
 *   depend on the threads and on the reading mode. Results must depend only
 *   on the points (unordered passes: sums and sets; ordered passes: the
 *   commits see the same points in the same order, with the same global
 *   indices, whatever the threads).
 * - counts: a pass over the whole cloud leaves the cloud's counts
 *   (wpd_cloud_delivered per file, wpd_cloud_dropped) as one reading of it
 *   would; a pass that ends early (end) leaves them untouched. Either way
 *   the cloud must be rewound before it is read again.
 * - memory: a lane costs wpd_pass_lane_bytes() (its batch and cloud) beside
 *   the caller's own per-lane state; callers count both in per_thread of
 *   wpd_budget_pass_threads, which gives `threads`.
 */
#ifndef WPD_PASS_H
#define WPD_PASS_H

#include <stdint.h>

#include "common/error.h"
#include "common/progress.h"
#include "io/cloud.h"

#define WPD_PASS_GID_UNKNOWN UINT64_MAX
#define WPD_PASS_MAX_UNIT (1u << 20) /* records of a unit at most (LAZ chunks) */
#define WPD_PASS_NO_UNIT UINT64_MAX

typedef struct wpd_pass_batch {
    const wpd_batch *batch;   /* the finite points read (owned by the pass) */
    int file;                 /* input file every point of the batch comes from */
    int lane;                 /* 0 .. threads-1: index of the caller's lane state */
    uint64_t first_gid;       /* global index of the first point, or
                                 WPD_PASS_GID_UNKNOWN (lane calls only) */
    uint64_t unit;            /* parallel reading: the unit read (wpd_pass_units
                                 numbers them); serial reading: WPD_PASS_NO_UNIT */
} wpd_pass_batch;

/* Returns 0, or -1 with err set; a commit may also return 1: the pass
 * needs no more batches (it ends after this one, no later commit). */
typedef int (*wpd_pass_fn)(void *arg, wpd_pass_batch *pb, wpd_error *err);

typedef struct wpd_pass {
    wpd_cloud *cloud;         /* read through clouds of the pass's own */
    int threads;              /* lanes (>= 1), from wpd_budget_pass_threads */
    uint64_t end;             /* records [0, end) at least; 0: the whole cloud.
                                 Serial reading may deliver batches past it. */
    int every_record_finite;  /* the caller knows no point is dropped (the
                                 scan counted wpd_cloud_count finite points) */
    wpd_pass_fn lane;         /* per batch, in parallel (may be NULL) */
    wpd_pass_fn commit;       /* per batch in reading order, or NULL: unordered */
    void *arg;                /* given to both */
    wpd_progress *progress;   /* a batch's points are added once it is done (lane,
                                 or commit when ordered); may be NULL */
    int share, shares;        /* shares >= 2 (unordered passes only): this process
                                 handles only the units (serial reading: the
                                 batches) whose number modulo shares is share, the
                                 others those of the other shares (the ranks of
                                 an MPI run); the cloud's counts are then left
                                 untouched. 0, 0: everything */
    uint64_t first_unit;      /* > 0 (ordered passes, parallel reading only): start
                                 at this unit, whose first finite point has the
                                 global index first_gid (wpd_pass_units); the
                                 cloud's counts are then left untouched */
    uint64_t first_gid;
    uint64_t *dropped;        /* or NULL: gets the non-finite points the reading of
                                 this process's units dropped (with shares and
                                 serial reading, where every process reads every
                                 batch: share 0 alone counts them), so that the
                                 shares' sum is the cloud's */
} wpd_pass;

/* The units a pass over the whole of c reads in parallel: their number in
 * *units (0 when c cannot seek: reading is serial). They depend on the
 * files alone, never on the threads or the pass, so that finite points
 * counted per unit in one pass (wpd_pass_batch.unit) tell a later pass
 * where a global index is (first_unit). Returns 0, or -1 with err set. */
int wpd_pass_units(const wpd_cloud *c, uint64_t *units, wpd_error *err);

/* Bytes one lane of a pass over c costs: its batch and its cloud. */
size_t wpd_pass_lane_bytes(const wpd_cloud *c);

/* Runs the pass. Returns 0, or -1 with err set: the first failure of a
 * read or a callback (WPD_E_MEMORY when the lanes' clouds and batches
 * cannot be had). */
int wpd_pass_run(const wpd_pass *pass, wpd_error *err);

#endif
