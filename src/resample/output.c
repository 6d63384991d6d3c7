/* output.c - the output stage (output.h). */
#include "resample/output.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/tmpdir.h"
#include "par/par.h"
#include "spill/run_merge.h"

int wpd_output_check(char *const *inputs, int ninputs, const char *path, const char *outdir,
                     int overwrite, wpd_error *err)
{
    struct stat st;
    for (int i = 0; i < (path ? 1 : ninputs); i++) {
        char out[WPD_PATH_BYTES];
        if (path)
            snprintf(out, sizeof out, "%s", path);
        else
            wpd_per_input_path(outdir, inputs[i], out, sizeof out);
        if (wpd_path_is_one_of(out, inputs, ninputs))
            return wpd_fail(err, WPD_E_USAGE, "%s: output is also an input", out);
        if (!overwrite && stat(out, &st) == 0)
            return wpd_fail(err, WPD_E_USAGE, "%s: output exists (use --force to replace it)",
                            out);
        /* Inputs of the same name in different folders: one output would
         * silently replace the other (outputs are renamed in together). */
        for (int j = 0; !path && j < i; j++) {
            char other[WPD_PATH_BYTES];
            wpd_per_input_path(outdir, inputs[j], other, sizeof other);
            if (!strcmp(out, other))
                return wpd_fail(err, WPD_E_USAGE, "%s: inputs %s and %s would both write it",
                                out, inputs[j], inputs[i]);
        }
    }
    return 0;
}

int wpd_output_keep_stale(char **inputs, int n, const char *outdir)
{
    int kept = 0;
    for (int i = 0; i < n; i++) {
        char out[WPD_PATH_BYTES];
        wpd_per_input_path(outdir, inputs[i], out, sizeof out);
        struct stat si, so;
        int fresh = stat(inputs[i], &si) == 0 && stat(out, &so) == 0 &&
                    (so.st_mtim.tv_sec > si.st_mtim.tv_sec ||
                     (so.st_mtim.tv_sec == si.st_mtim.tv_sec &&
                      so.st_mtim.tv_nsec >= si.st_mtim.tv_nsec));
        if (!fresh)
            inputs[kept++] = inputs[i];
    }
    return kept;
}

int wpd_output_files_open(wpd_output_files *p, const wpd_cloud *cloud, const char *outdir,
                          wpd_error *err)
{
    p->nout = outdir ? wpd_cloud_nfiles(cloud) : 1;
    p->outdir = outdir;
    p->files = malloc((size_t)(p->nout + 1) * sizeof *p->files);
    if (!p->files)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %d outputs", p->nout);
    wpd_outfile_clear_all(p->files, p->nout + 1);
    /* More finished outputs than the signal handlers' registry holds one
     * by one: they are removed as "this process's temporary outputs in
     * the folder". Without a slot, the next run's sweep removes them. */
    p->tracked = outdir && wpd_tmpdir_track_outputs(outdir) == 0;
    return 0;
}

void wpd_output_files_close(wpd_output_files *p)
{
    if (!p->files)
        return;
    wpd_outfile_abort_all(p->files, p->nout + 1);
    if (p->tracked)
        wpd_tmpdir_untrack_outputs(p->outdir);
    free(p->files);
    p->files = NULL;
}

/* The records source of a plain run: its runs merged in global-index
 * order (src: the result). */
static int records_of_run(void *src, wpd_cloud *cloud, size_t mem_bytes, int threads,
                          wpd_progress *progress, wpd_sample_sink sink, void *arg,
                          wpd_error *err)
{
    wpd_resample_result *res = src;
    wpd_run_merge *m;
    if (wpd_run_merge_open(res->samples, WPD_RUN_MERGE_BUDGET, &m, err))
        return -1;
    int rc = wpd_resample_stream_records(cloud, m, mem_bytes, threads, progress, sink, arg, err);
    wpd_run_merge_close(m);
    return rc;
}

/* The records source of one share of a plain run's samples (src: the
 * result, whose scan counted the points of each unit). */
static int records_share_of_run(void *src, wpd_cloud *cloud, uint64_t first, uint64_t count,
                                size_t mem_bytes, int threads, wpd_progress *progress,
                                wpd_sample_sink sink, void *arg, wpd_error *err)
{
    wpd_resample_result *res = src;
    wpd_run_merge *m;
    if (wpd_run_merge_open(res->samples, WPD_RUN_MERGE_BUDGET, &m, err))
        return -1;
    int rc = wpd_resample_stream_share(cloud, m, first, count, res->unit_points, res->nunits,
                                       mem_bytes, threads, progress, sink, arg, err);
    wpd_run_merge_close(m);
    return rc;
}

/* The records source of a run by class (src: the class result). */
static int records_by_class(void *src, wpd_cloud *cloud, size_t mem_bytes, int threads,
                            wpd_progress *progress, wpd_sample_sink sink, void *arg,
                            wpd_error *err)
{
    return wpd_class_stream_records(cloud, src, mem_bytes, threads, progress, sink, arg, err);
}


wpd_selection wpd_output_selection(wpd_resample_result *res, wpd_class_result *classes,
                                   int labelled)
{
    int by_class = classes && classes->ngroups;
    return (wpd_selection){res->count, res->file_samples, res->file_bounds, res->moved,
                           res->radius / 1000, labelled,
                           by_class ? records_by_class : records_of_run,
                           by_class ? (void *)classes : (void *)res,
                           res->unit_points && !by_class ? records_share_of_run : NULL, NULL};
}

int wpd_output_write(const wpd_selection *sel, wpd_cloud *cloud,
                     const wpd_selection_target *target, wpd_outfile *files, int *writers,
                     wpd_error *err)
{
    /* Every rank writes its share where the source allows; else rank 0
     * writes alone (docs/scale-out.md). */
    *writers = wpd_selection_shared(sel, target) ? wpd_par_ranks(target->par) : 1;
    if (*writers > 1)
        return wpd_selection_write_shared(sel, cloud, target, files, err);
    return wpd_par_rank(target->par) == 0 ? wpd_selection_write(sel, cloud, target, files, err)
                                          : 0;
}

void wpd_output_sweep_parts(const char *tmpdir, const char *output)
{
    const char *const parts[] = {".las", ".laz", ".ply", output ? output : ""};
    for (size_t i = 0; i < sizeof parts / sizeof *parts; i++) {
        char part[1100];
        wpd_outfile_sweep_stale(wpd_part_path(tmpdir, parts[i], part, sizeof part));
    }
}
