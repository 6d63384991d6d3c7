/* cloud.h - several input files read as one logical point cloud.
 *
 * All files must share one record layout (same format and dimensions; LAS
 * files may differ in scale and offset, since coordinates are delivered as
 * doubles). Headers are read when the cloud is opened; point data is read
 * one file at a time, so hundreds of tiles never hold hundreds of file
 * descriptors.
 */
#ifndef WPD_CLOUD_H
#define WPD_CLOUD_H

#include <stdio.h>

#include "common/error.h"
#include "io/batch.h"
#include "io/schema.h"

typedef struct wpd_bounds {
    double min[3], max[3];
    uint64_t count;            /* finite points seen */
} wpd_bounds;

typedef struct wpd_cloud wpd_cloud;

/* Opens and validates the headers of paths[0..n-1]. Returns NULL with err set
 * when a file cannot be read or the layouts differ. */
wpd_cloud *wpd_cloud_open(const char *const *paths, int n, wpd_error *err);

int wpd_cloud_nfiles(const wpd_cloud *c);
/* Header of file i (valid until close). File 0's schema is the cloud's. */
const wpd_header *wpd_cloud_header(const wpd_cloud *c, int i);
/* Total records declared by the headers (non-finite points included). */
uint64_t wpd_cloud_count(const wpd_cloud *c);

/* Reads the next batch, crossing file boundaries; every point of one batch
 * comes from one file, whose index is stored in *file (may be NULL).
 * Returns points read, 0 at the end of the last file, -1 with err set. */
long wpd_cloud_read(wpd_cloud *c, wpd_batch *b, int *file, wpd_error *err);
/* Another cloud over the same files with a reading position of its own,
 * for reading in parallel. Returns NULL with err set. */
wpd_cloud *wpd_cloud_reopen(const wpd_cloud *c, wpd_error *err);

/* From now on c (and every copy wpd_cloud_reopen makes of it, which must
 * be closed before c) keeps the records of its compressed files (LAZ with
 * a chunk table) as they are first decoded, in a record cache under base
 * (io/record_cache.h: a private directory, removed when c is closed and on
 * every exit path), and later reads take them from there instead of
 * decoding again: for runs that read their inputs several times. Files
 * that are read, not decoded, get no cache. Returns 0, or -1 with err set
 * (WPD_E_IO naming base, WPD_E_MEMORY). */
int wpd_cloud_cache_records(wpd_cloud *c, const char *base, wpd_error *err);

/* Records read back from c's caches so far, over all its copies. */
uint64_t wpd_cloud_cache_hits(const wpd_cloud *c);

/* 1 when every file's records can be positioned (wpd_cloud_seek_stretch
 * works anywhere), else 0 (ASCII PLY, PLY vertices with lists). */
int wpd_cloud_can_seek(const wpd_cloud *c);

/* Positions c at record `index` (counted over all files) and bounds its
 * reads to the stretch of at most `count` records from there that lies in
 * index's file: wpd_cloud_read then delivers the finite points of that
 * stretch and returns 0 at its end (until the next seek or rewind). For
 * reading a cloud in units of records on several threads (a file holds its
 * header's point_count records). Unlike a rewind, it keeps the counts
 * (wpd_cloud_delivered, wpd_cloud_dropped): a cloud that reads many
 * stretches has counted all of them; the
 * file's reader stays open from one stretch to the next in the same file.
 * Returns 0, or -1 with err set (WPD_E_USAGE when that file cannot seek). */
int wpd_cloud_seek_stretch(wpd_cloud *c, uint64_t index, uint64_t count, wpd_error *err);

/* Adds the counts of `from` (a wpd_cloud_reopen of c, or of the same
 * files) to c's: delivered points per file and dropped points. Lets a pass
 * that read through clouds of its own leave c counting what was read. */
void wpd_cloud_add_counts(wpd_cloud *c, const wpd_cloud *from);

/* Restarts reading at the first point of the first file. */
int wpd_cloud_rewind(wpd_cloud *c, wpd_error *err);
/* Points of file i delivered since the last rewind (finite points only). */
uint64_t wpd_cloud_delivered(const wpd_cloud *c, int i);

/* Non-finite points dropped so far over all files. */
uint64_t wpd_cloud_dropped(const wpd_cloud *c);

/* Classes: the values 0..WPD_CLASS_MAX of an integer field (LAS:
 * classification, its low 5 bits for point formats 0-5; PLY: a property
 * the caller names) that select the points a run sees. */
#define WPD_CLASS_MAX 65535

typedef struct wpd_point_filter {
    wpd_dim field;            /* the class field (as in every file's schema) */
    const uint8_t *accept;    /* [WPD_CLASS_MAX + 1]: 1 for the classes read */
} wpd_point_filter;

/* The class of one record of schema field f: its value, or -1 when it is
 * not an integer in 0..WPD_CLASS_MAX. */
long wpd_class_of(const wpd_dim *f, const uint8_t *record);

/* As wpd_class_of, with the one-line error (WPD_E_INPUT, naming path, the
 * field and the value) set in err when the value is not a class. */
long wpd_class_checked(const wpd_dim *f, const uint8_t *record, const char *path,
                       wpd_error *err);

/* From now on (and in its reopened copies) c delivers only the finite
 * points whose class f accepts (f, kept by the caller, outlives c; NULL:
 * every finite point again). The others are skipped and counted
 * (wpd_cloud_filtered), and global indices run over the points delivered,
 * so a run over a filtered cloud is the run over a file holding only those
 * points. A record whose class is out of range fails the read (WPD_E_INPUT,
 * naming the file and the field). */
void wpd_cloud_set_filter(wpd_cloud *c, const wpd_point_filter *f);
/* Finite points skipped by the filter so far over all files. */
uint64_t wpd_cloud_filtered(const wpd_cloud *c);

/* Streams the whole cloud once (from the start) computing the bounds of the
 * finite points, then rewinds. */
int wpd_cloud_bounds(wpd_cloud *c, wpd_bounds *out, wpd_error *err);

void wpd_cloud_close(wpd_cloud *c);

/* Prints the warnings of every file's header (what its reader read despite
 * the specification, see common/warnings.h) on f, file by file, so that
 * each file's are printed once. For the command line layer. */
void wpd_cloud_print_warnings(const wpd_cloud *c, const char *command, FILE *f);

/* The box the headers declare: 1 with out set (union of the boxes, count =
 * the declared records) when every file declares one (LAS) and no filter is
 * set (the box is every class's), else 0. */
int wpd_cloud_declared_bounds(const wpd_cloud *c, wpd_bounds *out);

/* Whether a declared box can stand for the actual one as the frame of a
 * run: it holds every point (the counts agree) and each face lies within
 * a millionth of the extent of the actual face. Both the in-memory and the
 * out-of-core paths choose their frame by this rule, so a cloud gives the
 * same samples on either; the engine then needs no bounds pass of its own
 * for LAS input. */
int wpd_bounds_tight(const wpd_bounds *declared, const wpd_bounds *actual);

/* Resets b to an empty box (min = +inf, max = -inf, count 0). */
void wpd_bounds_reset(wpd_bounds *b);
/* Extends b by the n points of xyz (3 doubles each). */
void wpd_bounds_add(wpd_bounds *b, const double *xyz, size_t n);
/* Extends b by the box o (counts summed): the box of both point sets. */
void wpd_bounds_union(wpd_bounds *b, const wpd_bounds *o);

#endif
