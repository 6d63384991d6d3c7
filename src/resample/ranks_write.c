/* ranks_write.c - the outputs written by every rank of an MPI run
 * (write.h: wpd_selection_shared, wpd_selection_write_shared): each rank
 * reads and writes its share, the parts are joined by offset, rank 0
 * finishes the output. */
#include "resample/write.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/bytes.h"
#include "io/laz/laz.h"
#include "resample/write_internal.h"

/* ---- one output written by every rank ---- */

int wpd_selection_shared(const wpd_selection *sel, const wpd_selection_target *target)
{
    return wpd_par_ranks(target->par) > 1 && sel->share_source && !sel->xyz_out;
}

/* Rank r's share of n samples: whole LAZ chunks but for the last rank's
 * (the same cut for every output format, so that the parts are simple). */
static void share_of(uint64_t n, int ranks, int r, uint64_t *first, uint64_t *count)
{
    uint64_t chunk = wpd_laz_chunk_points();
    uint64_t lo = (uint64_t)((unsigned __int128)n * (unsigned)r / (unsigned)ranks) / chunk * chunk;
    uint64_t hi = r + 1 == ranks ? n
                  : (uint64_t)((unsigned __int128)n * (unsigned)(r + 1) / (unsigned)ranks) /
                        chunk * chunk;
    *first = lo;
    *count = hi - lo;
}

/* Ranks after the first: a part writer in target->tmpdir, named with the
 * output's extension (which chooses LAS or LAZ). */
static int open_part(wpd_writing *ws, wpd_error *err)
{
    char part[1100];
    return wpd_writing_open(ws, 0, ws->target->path,
                       wpd_part_path(ws->target->tmpdir, ws->target->path, part, sizeof part),
                       err);
}

/* A part's facts (rank 0's with the output's temporary name and where its
 * records end) for the other ranks. */
static void pack_part(wpd_bytes *b, const wpd_write_part *p, const char *temp, uint64_t end)
{
    size_t tl = temp ? strlen(temp) : 0;
    wpd_bytes_put_u64(b, tl);
    wpd_bytes_put(b, temp ? temp : "", tl);
    wpd_bytes_put_u64(b, end);
    wpd_bytes_put_u64(b, p->count);
    wpd_bytes_put_u64(b, p->bytes);
    wpd_bytes_put(b, p->by_return, sizeof p->by_return);
    wpd_bytes_put(b, p->qmin, sizeof p->qmin);
    wpd_bytes_put(b, p->qmax, sizeof p->qmax);
    wpd_bytes_put_u64(b, p->nchunks);
    wpd_bytes_put(b, p->chunk_sizes, (size_t)p->nchunks * sizeof *p->chunk_sizes);
}

/* The facts pack_part packed; temp (1100 bytes) gets the name. Returns 0,
 * or -1 when the bytes are cut short. */
static int unpack_part(wpd_bytes_in *in, wpd_write_part *p, char *temp, uint64_t *end)
{
    uint64_t tl = wpd_bytes_get_u64(in);
    if (tl >= 1100 || wpd_bytes_get(in, temp, (size_t)tl))
        return -1;
    temp[tl] = '\0';
    *end = wpd_bytes_get_u64(in);
    p->count = wpd_bytes_get_u64(in);
    p->bytes = wpd_bytes_get_u64(in);
    wpd_bytes_get(in, p->by_return, sizeof p->by_return);
    wpd_bytes_get(in, p->qmin, sizeof p->qmin);
    wpd_bytes_get(in, p->qmax, sizeof p->qmax);
    p->nchunks = wpd_bytes_get_u64(in);
    if (in->bad || p->nchunks > wpd_bytes_left(in) / sizeof *p->chunk_sizes)
        return -1;
    p->chunk_sizes = (const uint32_t *)(in->p + in->at); /* aligned or not: memcpy'd */
    in->at += (size_t)p->nchunks * sizeof *p->chunk_sizes;
    return 0;
}

/* Every rank's part facts to every rank (all: the caller frees it). */
static int exchange_parts(const wpd_par *par, int rc, wpd_writing *ws, const wpd_write_part *mine,
                          uint8_t **all, size_t *off, size_t *len, wpd_error *err)
{
    wpd_bytes b = {0};
    int first = wpd_par_rank(par) == 0;
    if (rc == 0) {
        pack_part(&b, mine, first ? wpd_writer_temp_path(ws->w) : NULL,
                  first ? wpd_writer_records_end(ws->w) : 0);
        if (b.failed)
            rc = wpd_fail(err, WPD_E_MEMORY, "out of memory");
    }
    if (rc == 0)
        wpd_error_clear(err);
    rc = wpd_par_agree(par, err) || wpd_par_gather_all(par, b.p, b.len, all, off, len, err)
             ? -1 : 0;
    wpd_bytes_free(&b);
    return rc;
}

/* Ranks after the first put their part's bytes into the output; rank 0
 * adds every other part's facts, in rank order. */
static int join_parts(wpd_writing *ws, const uint8_t *all, const size_t *off, const size_t *len,
                      wpd_error *err)
{
    const wpd_par *par = ws->target->par;
    int ranks = wpd_par_ranks(par), me = wpd_par_rank(par);
    char temp[1100], ignored[1100];
    uint64_t at = 0, unused;
    for (int k = 0; k < ranks; k++) {
        wpd_bytes_in in = {all + off[k], len[k], 0, 0};
        wpd_write_part p;
        if (unpack_part(&in, &p, k ? ignored : temp, k ? &unused : &at))
            return wpd_fail(err, WPD_E_IO, "%s: a rank's part facts are cut short",
                            ws->target->path);
        uint32_t *sizes = NULL;
        if (me == 0 && k > 0 && p.nchunks) { /* aligned copy of the sizes */
            if (!(sizes = malloc((size_t)p.nchunks * sizeof *sizes)))
                return wpd_fail(err, WPD_E_MEMORY, "out of memory");
            memcpy(sizes, p.chunk_sizes, (size_t)p.nchunks * sizeof *sizes);
            p.chunk_sizes = sizes;
        }
        int rc = 0;
        if (k > 0 && k == me)
            rc = wpd_writer_place_part(ws->w, temp, at, err);
        else if (k > 0 && me == 0)
            rc = wpd_writer_add_part(ws->w, &p, err);
        free(sizes);
        if (rc)
            return -1;
        if (k > 0)
            at += p.bytes;
    }
    return 0;
}

/* One output written by every rank (wpd_selection_write_shared). */
static int write_one_shared(const wpd_selection *sel, wpd_cloud *cloud,
                            const wpd_selection_target *target, wpd_outfile *pending,
                            wpd_error *err)
{
    const wpd_par *par = target->par;
    int me = wpd_par_rank(par);
    uint64_t first, count;
    share_of(sel->n, wpd_par_ranks(par), me, &first, &count);
    wpd_writing ws = {.sel = sel, .cloud = cloud, .target = target, .pending = pending,
                  .limit = count};
    wpd_write_part mine;
    int rc = wpd_writing_boxes(&ws, err);
    if (rc == 0 && pending)
        wpd_outfile_clear_all(pending, 1);
    if (rc == 0)
        rc = me == 0 ? wpd_writing_open_next(&ws, err) : open_part(&ws, err);
    if (rc == 0)
        rc = sel->share_source(sel->source_arg, cloud, first, count, target->mem_bytes,
                               target->threads, target->progress, wpd_writing_sink, &ws, err);
    if (rc == 0 && ws.written != count)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                      wpd_cloud_header(cloud, 0)->path);
    if (rc == 0)
        rc = wpd_writer_end_part(ws.w, &mine, err);
    uint8_t *all = NULL;
    size_t ranks = (size_t)wpd_par_ranks(par);
    size_t *off = calloc(ranks, sizeof *off), *len = calloc(ranks, sizeof *len);
    if (rc == 0 && (!off || !len))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory");
    /* A failed exchange failed on every rank: on to the closing agreement. */
    rc = exchange_parts(par, rc, &ws, &mine, &all, off, len, err);
    if (rc == 0) {
        /* Every part is in the output before rank 0 finishes it. */
        if (join_parts(&ws, all, off, len, err) == 0)
            wpd_error_clear(err);
        rc = wpd_par_agree(par, err);
    }
    free(all);
    free(off);
    free(len);
    if (rc == 0 && me == 0)
        rc = wpd_writing_close(&ws, err);
    if (ws.open) { /* a part (its bytes are in the output), or a failure */
        wpd_writer_abort(ws.w);
        wpd_header_free(&ws.out);
    }
    wpd_batch_free(&ws.dst);
    free(ws.box);
    if (rc && pending)
        wpd_outfile_abort_all(pending, 1);
    return rc;
}

/* --per-input: rank r's outputs, files [*lo, *hi): file f goes to the
 * rank its first sample's place in the output falls to, so that the ranks
 * get runs of whole files of about n / K samples each. */
static void files_of(const wpd_selection *sel, int nfiles, int ranks, int r, int *lo, int *hi)
{
    uint64_t before = 0;
    *lo = *hi = nfiles;
    for (int f = 0; f < nfiles; f++) {
        int owner = (int)((unsigned __int128)before * (unsigned)ranks / (sel->n ? sel->n : 1));
        owner = owner < ranks ? owner : ranks - 1;
        if (owner == r && *lo == nfiles)
            *lo = f;
        if (owner > r && *hi == nfiles)
            *hi = f;
        before += sel->file_samples[f];
    }
    if (*lo > *hi)
        *lo = *hi;
}

/* The ranks' temporary output names to every rank; rank 0 takes those of
 * the other ranks' files into pending (it renames them all). */
static int gather_names(wpd_writing *ws, int rc, int lo, int hi, wpd_error *err)
{
    const wpd_par *par = ws->target->par;
    size_t ranks = (size_t)wpd_par_ranks(par);
    wpd_bytes b = {0};
    for (int k = lo; rc == 0 && k < hi; k++) {
        size_t n = strlen(ws->pending[k].temp_path);
        wpd_bytes_put_u64(&b, n);
        wpd_bytes_put(&b, ws->pending[k].temp_path, n);
    }
    uint8_t *all = NULL;
    size_t *off = calloc(ranks, sizeof *off), *len = calloc(ranks, sizeof *len);
    if (rc == 0 && (b.failed || !off || !len))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (rc == 0)
        wpd_error_clear(err);
    /* A failure anywhere makes every rank fail at the agreement. */
    rc = wpd_par_agree(par, err) || wpd_par_gather_all(par, b.p, b.len, &all, off, len, err)
             ? -1 : 0;
    for (size_t r = 1; rc == 0 && wpd_par_rank(par) == 0 && r < ranks; r++) {
        wpd_bytes_in in = {all + off[r], len[r], 0, 0};
        int first, last;
        files_of(ws->sel, ws->nout, (int)ranks, (int)r, &first, &last);
        for (int k = first; rc == 0 && k < last; k++) {
            wpd_outfile *f = &ws->pending[k];
            uint64_t n = wpd_bytes_get_u64(&in);
            if (in.bad || n >= sizeof f->temp_path || wpd_bytes_get(&in, f->temp_path, n)) {
                rc = wpd_fail(err, WPD_E_IO, "%s: a rank's output names are cut short",
                              ws->target->outdir);
                break;
            }
            f->temp_path[n] = '\0';
            f->fd = -1;
            wpd_per_input_path(ws->target->outdir, wpd_writing_input(ws, k)->path, f->final_path,
                               sizeof f->final_path);
        }
    }
    wpd_bytes_free(&b);
    free(all);
    free(off);
    free(len);
    return rc;
}

/* --per-input by every rank: each writes the outputs of its files. */
static int write_files_shared(const wpd_selection *sel, wpd_cloud *cloud,
                              const wpd_selection_target *target, wpd_outfile *pending,
                              wpd_error *err)
{
    int ranks = wpd_par_ranks(target->par);
    wpd_writing ws = {.sel = sel, .cloud = cloud, .target = target, .pending = pending};
    int rc = wpd_writing_boxes(&ws, err), lo = ws.nout, hi = ws.nout;
    uint64_t first = 0, count = 0;
    if (rc == 0) {
        wpd_outfile_clear_all(pending, ws.nout);
        files_of(sel, ws.nout, ranks, wpd_par_rank(target->par), &lo, &hi);
        for (int f = 0; f < hi; f++)
            *(f < lo ? &first : &count) += sel->file_samples[f];
        ws.done = lo;
        ws.limit = count;
        rc = sel->share_source(sel->source_arg, cloud, first, count, target->mem_bytes,
                               target->threads, target->progress, wpd_writing_sink, &ws, err);
    }
    if (rc == 0 && ws.written != count)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                      wpd_cloud_header(cloud, 0)->path);
    if (rc == 0)
        rc = wpd_writing_finish_before(&ws, hi, err); /* the outputs after the last point */
    if (ws.open) {
        wpd_writer_abort(ws.w);
        wpd_header_free(&ws.out);
    }
    rc = gather_names(&ws, rc, lo, hi, err);
    wpd_batch_free(&ws.dst);
    free(ws.box);
    if (rc && ws.nout)
        wpd_outfile_abort_all(pending, ws.nout);
    return rc;
}

int wpd_selection_write_shared(const wpd_selection *sel, wpd_cloud *cloud,
                               const wpd_selection_target *target, wpd_outfile *pending,
                               wpd_error *err)
{
    return target->path ? write_one_shared(sel, cloud, target, pending, err)
                        : write_files_shared(sel, cloud, target, pending, err);
}
