/* writer.c - dispatch to the per-format writers around a temp-then-rename
 * output file. */
#include "io/format.h"
#include "io/layout.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The file position of w's output. */
static uint64_t position(const wpd_writer *w)
{
    off_t at = lseek(w->out.fd, 0, SEEK_CUR);
    return at < 0 ? 0 : (uint64_t)at;
}

static wpd_writer *open_writer(const char *path, const wpd_header *hdr,
                               const wpd_write_options *opt, int part, wpd_error *err)
{
    if (hdr->format != WPD_FMT_LAS && hdr->format != WPD_FMT_PLY) {
        wpd_fail(err, WPD_E_USAGE, "%s: no output format", path);
        return NULL;
    }
    wpd_writer *w = calloc(1, sizeof *w);
    if (!w || wpd_header_copy(&w->hdr, hdr)) {
        free(w);
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
        return NULL;
    }
    if (opt)
        w->opt = *opt;
    w->part = part;
    snprintf(w->hdr.path, sizeof w->hdr.path, "%s", path);
    /* LAS or LAZ by the name, whatever the input was: the LAZ facts of a
     * compressed input describe its encoding, not the output's. */
    if (w->hdr.format == WPD_FMT_LAS)
        w->hdr.las.laz = (wpd_laz_info){.compressed = wpd_format_is_laz_name(path)};
    if (wpd_outfile_open(&w->out, path, w->opt.overwrite, err)) {
        wpd_header_free(&w->hdr);
        free(w);
        return NULL;
    }
    int rc = hdr->format == WPD_FMT_LAS ? wpd_las_open_writer(w, err)
                                        : wpd_ply_open_writer(w, err);
    if (rc) {
        wpd_writer_abort(w);
        return NULL;
    }
    w->records_start = position(w);
    return w;
}

wpd_writer *wpd_writer_open(const char *path, const wpd_header *hdr,
                            const wpd_write_options *opt, wpd_error *err)
{
    return open_writer(path, hdr, opt, 0, err);
}

wpd_writer *wpd_writer_open_part(const char *path, const wpd_header *hdr,
                                 const wpd_write_options *opt, wpd_error *err)
{
    wpd_write_options o = opt ? *opt : (wpd_write_options){0};
    o.overwrite = 1; /* a part's name is never taken: only its temporary one */
    return open_writer(path, hdr, &o, 1, err);
}

int wpd_writer_end_part(wpd_writer *w, wpd_write_part *part, wpd_error *err)
{
    memset(part, 0, sizeof *part);
    if (w->ops->end_part(w, part, err))
        return -1;
    part->count = w->count;
    part->bytes = position(w) - w->records_start;
    return 0;
}

int wpd_writer_add_part(wpd_writer *w, const wpd_write_part *part, wpd_error *err)
{
    if (w->ops->add_part(w, part, err))
        return -1;
    w->count += part->count;
    if (lseek(w->out.fd, (off_t)part->bytes, SEEK_CUR) < 0)
        return wpd_fail(err, WPD_E_IO, "%s: %s", w->out.final_path, strerror(errno));
    return 0;
}

const char *wpd_writer_temp_path(const wpd_writer *w) { return w->out.temp_path; }

int wpd_writer_place_part(const wpd_writer *w, const char *temp_path, uint64_t off,
                          wpd_error *err)
{
    wpd_outfile dest = {.fd = -1};
    snprintf(dest.final_path, sizeof dest.final_path, "%s", w->out.final_path);
    snprintf(dest.temp_path, sizeof dest.temp_path, "%s", temp_path);
    return wpd_outfile_place(&w->out, position(w) - w->records_start, &dest, off, err);
}

uint64_t wpd_writer_records_end(const wpd_writer *w) { return position(w); }

int wpd_writer_write(wpd_writer *w, const wpd_batch *b, wpd_error *err)
{
    if (b->record_size != w->hdr.schema.record_size)
        return wpd_fail(err, WPD_E_USAGE, "%s: batch record size %u does not match %u",
                        w->out.final_path, b->record_size, w->hdr.schema.record_size);
    return w->ops->write(w, b, err);
}

static void free_writer(wpd_writer *w)
{
    if (w->ops && w->ops->close)
        w->ops->close(w);
    wpd_header_free(&w->hdr);
    free(w);
}

int wpd_writer_close(wpd_writer *w, wpd_error *err)
{
    int rc = w->ops->finish(w, err);
    if (rc == 0)
        rc = wpd_outfile_commit(&w->out, err);
    else
        wpd_outfile_abort(&w->out);
    free_writer(w);
    return rc;
}

int wpd_writer_close_pending(wpd_writer *w, wpd_outfile *done, wpd_error *err)
{
    int rc = w->ops->finish(w, err);
    if (rc == 0)
        rc = wpd_outfile_finish(&w->out, err);
    else
        wpd_outfile_abort(&w->out);
    *done = w->out;
    if (rc) {
        done->fd = -1;
        done->temp_path[0] = '\0';
    }
    free_writer(w);
    return rc;
}

void wpd_writer_abort(wpd_writer *w)
{
    if (!w)
        return;
    wpd_outfile_abort(&w->out);
    free_writer(w);
}

uint64_t wpd_writer_count(const wpd_writer *w) { return w->count; }
