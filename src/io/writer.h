/* writer.h - streaming point writers, one interface for every format.
 *
 * The output goes to a temporary file in the output's directory and is
 * renamed over the final name only by wpd_writer_close, so a failed or
 * interrupted run never leaves a partial file under the output name.
 */
#ifndef WPD_WRITER_H
#define WPD_WRITER_H

#include "common/error.h"
#include "common/outfile.h"
#include "io/batch.h"
#include "io/schema.h"

typedef struct wpd_writer wpd_writer;

typedef struct wpd_write_options {
    int ply_ascii;          /* PLY: write ascii instead of binary little-endian */
    int overwrite;          /* replace an existing file at path */
} wpd_write_options;

/* Creates a writer for the file described by hdr: hdr->format selects the
 * format, hdr->schema the record layout of the batches that will be written,
 * and the format's info block the header facts to carry over (LAS version,
 * PDRF, scale, offset, VLRs, EVLRs; PLY comments and obj_info). Counts,
 * bounds and return histograms are recomputed from the points written.
 * Returns NULL with err set on failure. hdr is copied. */
wpd_writer *wpd_writer_open(const char *path, const wpd_header *hdr,
                            const wpd_write_options *opt, wpd_error *err);

/* Appends the points of b. Records are in the writer's schema; the x, y, z
 * fields of each record are overwritten from b->xyz (LAS: quantised with the
 * header's scale and offset; a coordinate that does not fit is an error).
 * Returns 0, or -1 with err set. */
int wpd_writer_write(wpd_writer *w, const wpd_batch *b, wpd_error *err);

/* Finishes the header, flushes, renames the temporary file to the final
 * path and frees the writer. Returns 0, or -1 with err set (the temporary
 * file is then removed and the writer freed). */
int wpd_writer_close(wpd_writer *w, wpd_error *err);

/* Like wpd_writer_close, but leaves the complete file under its temporary
 * name, described by *done: wpd_outfile_rename puts it in place and
 * wpd_outfile_abort removes it (for outputs that appear together or not at
 * all). The writer is freed. Returns 0, or -1 with err set (the temporary
 * file is then removed). */
int wpd_writer_close_pending(wpd_writer *w, wpd_outfile *done, wpd_error *err);

/* Removes the temporary file and frees the writer. NULL is allowed. */
void wpd_writer_abort(wpd_writer *w);

/* Points written so far. */
uint64_t wpd_writer_count(const wpd_writer *w);

#endif
