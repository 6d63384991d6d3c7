/* write_internal.h - the state of the outputs being written, shared by
 * the one-process writer (write.c) and the ranks' shared writing
 * (ranks_write.c). Internal to src/resample/. */
#ifndef WPD_WRITE_INTERNAL_H
#define WPD_WRITE_INTERNAL_H

#include "io/batch.h"
#include "io/layout.h"
#include "resample/write.h"

/* The outputs being written, and the records pass's sink state. */
typedef struct wpd_writing {
    const wpd_selection *sel;
    const wpd_cloud *cloud;
    const wpd_selection_target *target;
    wpd_outfile *pending;
    int nout;
    wpd_bounds *box;          /* [nout]: the box of output k's points */
    size_t written;           /* points handed to the outputs so far */
    uint64_t limit;           /* points this process writes */
    int done;                 /* outputs 0..done-1 finished */
    int open;                 /* output `done` is open */
    wpd_writer *w;
    wpd_header out;
    wpd_layout_map map;
    int label;
    wpd_batch dst;
} wpd_writing;

/* The input header whose layout output k takes (one output: the first
 * file's). */
const wpd_header *wpd_writing_input(const wpd_writing *ws, int k);

/* Opens the writer of output k (path: its name, which chooses the
 * format), or with part a part writer of it into that file (io/writer.h).
 * Returns 0, or -1 with err set. */
int wpd_writing_open(wpd_writing *ws, int k, const char *path, const char *part,
                     wpd_error *err);

/* Opens output ws->done under its final name's temporary. */
int wpd_writing_open_next(wpd_writing *ws, wpd_error *err);

/* Finishes the open output under its temporary name (pending[done]). */
int wpd_writing_close(wpd_writing *ws, wpd_error *err);

/* Finishes every output before k (empty ones included). */
int wpd_writing_finish_before(wpd_writing *ws, int k, wpd_error *err);

/* The sink of the records pass (wpd_sample_sink, arg a wpd_writing): n
 * samples of input file `file`, in the input's layout, to the open
 * output's layout, written. */
int wpd_writing_sink(void *arg, int file, const double *xyz, const uint8_t *edge,
                     const uint8_t *records, size_t n, wpd_error *err);

/* Allocates and fills ws->box: the box of each output's points (one
 * output's is every file's); sets ws->nout. */
int wpd_writing_boxes(wpd_writing *ws, wpd_error *err);

#endif
