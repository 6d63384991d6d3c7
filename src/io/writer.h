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

/* ---- One output written by several processes ----
 * (the ranks of an MPI run, docs/scale-out.md). The first process opens
 * the output (wpd_writer_open) and writes its points; each other writes
 * its points, which follow them in the output, into a part file of its
 * own (wpd_writer_open_part). Every one then ends its part
 * (wpd_writer_end_part) and the parts' facts travel to all: a part's
 * bytes go into the output after the first process's and the parts before
 * it (LAZ and ASCII PLY sizes are known only once encoded), and the first
 * process adds the facts of the others, in order (wpd_writer_add_part),
 * before it closes the output. For LAZ, every part but the last must hold
 * whole chunks (a multiple of wpd_laz_chunk_points() points): the output is
 * then the bytes one process writes. */

/* What a part holds, for the output's header and tables. */
typedef struct wpd_write_part {
    uint64_t count;           /* points */
    uint64_t bytes;           /* bytes of their records (LAZ: chunks) */
    uint64_t by_return[16];   /* LAS: points per return number */
    int32_t qmin[3], qmax[3]; /* LAS: box of the quantised coordinates */
    uint64_t nchunks;         /* LAZ: its chunks and their byte sizes */
    const uint32_t *chunk_sizes;
} wpd_write_part;

/* A writer of the records alone (no header, no VLRs, no chunk table) of
 * the output hdr describes, into the file at path (created under a
 * temporary name beside it, as wpd_writer_open; it is never renamed:
 * wpd_writer_abort removes it once its bytes are placed). */
wpd_writer *wpd_writer_open_part(const char *path, const wpd_header *hdr,
                                 const wpd_write_options *opt, wpd_error *err);

/* Ends the points of this writer's part: everything buffered is written
 * (LAZ: the open chunk closed), *part describes them (chunk_sizes point
 * into the writer: valid until it is freed). No point may be written
 * after it. Returns 0, or -1 with err set. */
int wpd_writer_end_part(wpd_writer *w, wpd_write_part *part, wpd_error *err);

/* The first process's writer (after its own wpd_writer_end_part): adds
 * part, whose bytes another process puts into the file right after the
 * records so far. Returns 0, or -1 with err set (too many points for the
 * format). */
int wpd_writer_add_part(wpd_writer *w, const wpd_write_part *part, wpd_error *err);

/* The temporary file the writer writes and the file offset the next
 * record goes to: where the next part's bytes belong. */
const char *wpd_writer_temp_path(const wpd_writer *w);
uint64_t wpd_writer_records_end(const wpd_writer *w);

/* A part writer's bytes (after wpd_writer_end_part) into the output being
 * written under temp_path (the first process's wpd_writer_temp_path), at
 * offset off; flushed to disk. Returns 0, or -1 with err set. */
int wpd_writer_place_part(const wpd_writer *w, const char *temp_path, uint64_t off,
                          wpd_error *err);

#endif
