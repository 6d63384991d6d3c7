/* collection.h - a collection: outputs resampled on different nights that
 * join as if resampled together (docs/ingest.md).
 *
 * `wpd resample --per-input DIR` (or `-o OUT --append`) keeps the state of
 * its outputs in DIR/.wpd-collection (.OUT.wpd-collection beside OUT): the
 * working radius r and density factor f of the collection, the options
 * that shape samples, and for each input resampled so far its file's name,
 * size, mtime and box, where its samples are (output, records, box) and
 * the night that wrote them. The first night (no state, or --rebuild) is
 * an ordinary run; r is its final radius and f its count over its Poisson
 * pass's (--spacing D: r = D, one pass, f = 1). A later night resamples
 * only the inputs not in the state, in one Poisson pass at r, keeps
 * round(f x that pass), and holds fixed the samples earlier nights wrote
 * within reach (3 r) of its inputs (resample.h: fixed_xyz), read from
 * the outputs whose boxes come that close: no seam, and a night's work
 * does not grow with the collection.
 *
 * The state file is the commit point (collection_commit.c): the night's
 * outputs are finished under temporary names, the new state is written
 * beside the old one with the renames still to do, renamed over it, then
 * the renames are done and the state written again without them. A run
 * that finds a state with renames to do completes them; one that finds a
 * new state never committed, or the mark of a night that died before,
 * rolls it back.
 *
 * The state is JSON written with common/json.h and read by a strict
 * parser of this format alone (collection_parse.c): anything else is one
 * line, WPD_E_INPUT, and nothing is written. Only rank 0 of an MPI run
 * reads and writes it; the night's plan is handed to every rank.
 */
#ifndef WPD_COLLECTION_H
#define WPD_COLLECTION_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "common/outfile.h"
#include "io/cloud.h"
#include "method/params.h"
#include "par/par.h"

#define WPD_COLLECTION_FORMAT 1

/* The options that shape samples, as the state keeps them (class lists
 * as text, "2,6,9-12"; "" none). */
typedef struct wpd_coll_options {
    double lambda, voxel_frac;
    int radius_method, k, iterations, even_steps, smooth, sharp;
    uint64_t seed;
    char *drop, *keep;        /* malloc'd */
    char *class_field;        /* malloc'd; "" the default */
} wpd_coll_options;

/* One input resampled by a night. Boxes: min x y z, max x y z (absolute;
 * an empty box as +inf, -inf). */
typedef struct wpd_coll_input {
    char *name;               /* the input's file name */
    uint64_t size;
    int64_t mtime_ns;
    double bounds[6];         /* its points' box (LAS: the header's) */
    char *output;             /* the output holding its samples (a file name in dir) */
    uint64_t first, points;   /* its records there (samples and kept classes) */
    double out_bounds[6];     /* their box */
    int night;
} wpd_coll_input;

typedef struct wpd_coll_output {
    char *name;               /* a file name in dir */
    uint64_t size;
} wpd_coll_output;

typedef struct wpd_coll_rename {
    char *from, *to;          /* file names in dir: temporary -> final */
} wpd_coll_rename;

typedef struct wpd_collection {
    char dir[1024];           /* the outputs' folder */
    char state[1400];         /* the state file */
    char label[1024];         /* what messages name: DIR, or OUT with --append */
    char append[256];         /* --append: OUT's file name; else "" */
    int exists;               /* a state was read */
    char wpd_version[64];     /* the wpd that wrote it */
    double radius, factor;
    int spacing;              /* 1: r was given (--spacing) */
    wpd_coll_options opt;
    int nights;
    int noutputs, ninputs, npending;
    wpd_coll_output *outputs;
    wpd_coll_input *inputs;
    wpd_coll_rename *pending;
    struct wpd_coll_name *by_name; /* the inputs' names sorted (wpd_collection_find) */
} wpd_collection;

/* A name and its place, for sorted lookups: a night looks its inputs up in
 * the state, and the state checks its own names, in n log n, not n^2 (a
 * collection of 10 000 tiles). */
typedef struct wpd_coll_name {
    const char *name;
    int at;
} wpd_coll_name;

/* names[0..n-1] sorted by name. */
void wpd_coll_names_sort(wpd_coll_name *names, int n);
/* The place of name among sorted names, or -1. */
int wpd_coll_names_find(const wpd_coll_name *names, int n, const char *name);

/* The state's input called name, or NULL (after wpd_collection_load or
 * _parse, which sort the index). */
const wpd_coll_input *wpd_collection_find(const wpd_collection *c, const char *name);

/* Where the collection of a --per-input folder (outdir) or of an
 * --append output (path) lives; nothing is read. Returns 0, or -1 with
 * err set (a path too long). */
int wpd_collection_locate(wpd_collection *c, const char *outdir, const char *path,
                          wpd_error *err);

void wpd_collection_free(wpd_collection *c);
void wpd_coll_options_free(wpd_coll_options *o);

/* The class list of set ([WPD_CLASS_MAX + 1] or NULL) as text, "2,6,9-12"
 * ("" for none), malloc'd; NULL when out of memory. */
char *wpd_coll_class_list(const uint8_t *set);

/* ---------------------------------------------------------- the state file */

/* Reads the state into c (c->exists = 0 when there is none). Returns 0, or
 * -1 with err set: WPD_E_INPUT for a file that is not a state of this
 * format version ("DIR/.wpd-collection: ..."), WPD_E_IO when it cannot be
 * read. */
int wpd_collection_load(wpd_collection *c, wpd_error *err);

/* Parses text (len bytes) as a state into c (collection_parse.c). Returns
 * 0, or -1 with err set (WPD_E_INPUT naming `name`, the byte and what was
 * expected). */
int wpd_collection_parse(wpd_collection *c, const char *text, size_t len, const char *name,
                         wpd_error *err);

/* c as the state's JSON text (with its pending renames), malloc'd into
 * *text. Returns 0 or -1 (out of memory). */
int wpd_collection_format(const wpd_collection *c, char **text, size_t *len);

/* ---------------------------------------------------------- the night */

/* What the command asks of a night. */
typedef struct wpd_night_request {
    wpd_coll_options opt;     /* this run's (borrowed strings) */
    const uint8_t *keep;      /* --keep-class's set ([WPD_CLASS_MAX + 1]) or NULL: the
                                 kept points in earlier outputs are no samples */
    double spacing;           /* --spacing, or 0 */
    int rebuild;              /* --rebuild */
    int skip_existing;        /* --skip-existing */
    const wpd_par *par;
} wpd_night_request;

/* The night to run, the same on every rank. */
typedef struct wpd_night {
    int number;               /* 1, 2, ... */
    int later;                /* 1: resample at the collection's radius, with fixed
                                 samples; 0: a first night */
    int nnew, skipped;        /* new inputs (moved to the front); inputs in the
                                 collection already, unchanged */
    double radius, factor;    /* a later night's, or --spacing's (factor 1) */
    double *fixed;            /* [3 nfixed] absolute: earlier nights' samples */
    size_t nfixed;
    int outputs_read;         /* earlier outputs they were read from */
    wpd_coll_input *fresh;    /* [nnew] (rank 0) the new inputs' file facts */
} wpd_night;

void wpd_night_free(wpd_night *n);

/* Rank 0: reads the state and checks it against req (options: WPD_E_USAGE
 * naming the option; outputs missing or changed: WPD_E_INPUT), sorts the
 * inputs (new ones first: those not in the state; unchanged ones skipped;
 * a changed one refused, WPD_E_USAGE), and for a later night reads the
 * fixed samples. Every rank then gets the plan (inputs reordered alike).
 * Every rank calls it. Returns 0, or -1 with err set and nothing
 * written. */
int wpd_collection_plan(wpd_collection *c, const wpd_night_request *req, char **inputs,
                        int ninputs, wpd_night *night, wpd_error *err);

/* The samples earlier nights wrote within reach of the new inputs' boxes
 * (collection_fixed.c): the outputs whose boxes come within reach are read
 * (the records of the inputs there), their points within reach kept,
 * kept classes (keep, or NULL) left out. Returns 0, or -1 with err set. */
int wpd_collection_fixed(const wpd_collection *c, wpd_night *night, double reach,
                         const uint8_t *keep, const char *class_field, wpd_error *err);

/* The box and file facts of each new input into night->fresh (stat; LAS
 * header boxes, else a pass over the points). Returns 0, or -1 with err
 * set. */
int wpd_collection_facts(char *const *inputs, wpd_night *night, wpd_error *err);

/* What a night wrote, for the state: per new input the records it has in
 * its output and their box. */
typedef struct wpd_night_result {
    double radius, factor;    /* a first night's r and f */
    const uint64_t *points;   /* [nnew] */
    const wpd_bounds *bounds; /* [nnew] */
    const wpd_outfile *files; /* the night's outputs under temporary names */
    int nfiles;
    uint64_t first;           /* --append: records OUT held before the night */
} wpd_night_result;

/* Rank 0: the state after the night (c updated in place: the new inputs,
 * their outputs with the sizes of the finished temporaries, the pending
 * renames). Returns 0, or -1 with err set. */
int wpd_collection_record(wpd_collection *c, const wpd_night_request *req,
                          const wpd_night *night, const wpd_night_result *res,
                          wpd_error *err);

/* ---------------------------------------------------------- commit, recovery */

/* Commits the night recorded in c (collection_commit.c): writes the new
 * state beside the old one (fsync), then with the signals held back
 * renames it over the old one (the commit), renames files[0..n-1] into
 * place, syncs the folder and writes the state without its renames; the
 * report (report, may be NULL) is renamed last. Stop points "commit"
 * (the new state written) and "renames" (committed). Returns 0, or -1
 * with err set: before the commit nothing is left; after it, the next run
 * completes the renames. */
int wpd_collection_commit(wpd_collection *c, wpd_outfile *files, int n, wpd_outfile *report,
                          wpd_error *err);

/* With the collection's lock held, before any sweep of stale files:
 * completes a night that was committed but not finished, or rolls back
 * one that died before its commit (its new state, its mark and its
 * temporaries). *said: 1 completed, 2 rolled back, 0 nothing to do.
 * Returns 0, or -1 with err set. */
int wpd_collection_recover(wpd_collection *c, int *said, wpd_error *err);

/* The mark of a night in progress (rank 0, after recovery): a file that a
 * night killed outright leaves, so that the next run can say it rolled it
 * back; removed on every other path (and by the signal handlers). */
int wpd_collection_mark(const wpd_collection *c, wpd_error *err);
void wpd_collection_unmark(const wpd_collection *c);

/* 1 if path names a file the collection keeps, whether it exists yet or
 * not: its state, the state's ".new" and ".run" files beside it, or an
 * output the state records (after a load). */
int wpd_collection_owns(const wpd_collection *c, const char *path);

#endif
