/* output.h - the output stage of `wpd resample`: which outputs a run makes
 * and whether it may make them, the selection of a run's samples (their
 * records read once more from the inputs while they are written, write.h),
 * written by one process or shared by every rank, each output finished
 * under a temporary name until the caller renames them all together. */
#ifndef WPD_OUTPUT_H
#define WPD_OUTPUT_H

#include "common/error.h"
#include "common/outfile.h"
#include "io/cloud.h"
#include "resample/classes.h"
#include "resample/resample.h"
#include "resample/write.h"

/* Refuses, before any work, outputs that exist (unless overwrite) or that
 * are inputs: the one output path, or with path NULL one per input in
 * outdir (two inputs of one file name would write the same output).
 * Returns 0, or -1 with err set (WPD_E_USAGE). */
int wpd_output_check(char *const *inputs, int ninputs, const char *path, const char *outdir,
                     int overwrite, wpd_error *err);

/* --skip-existing: moves the inputs that still need work to the front of
 * inputs and returns how many there are. An input needs work unless its
 * output in outdir exists and is at least as new. */
int wpd_output_keep_stale(char **inputs, int n, const char *outdir);

/* The outputs of a run and its report, finished under temporary names
 * until they are renamed together (wpd_outfile_rename_all over nout + 1):
 * files[0..nout-1] the outputs, files[nout] the report. */
typedef struct wpd_output_files {
    wpd_outfile *files;
    int nout;
    const char *outdir;       /* the --per-input folder, or NULL */
    int tracked;              /* its temporary outputs are tracked (tmpdir.h) */
} wpd_output_files;

/* Room for one output, or with outdir one per input file of cloud, and
 * the report. Returns 0, or -1 with err set. */
int wpd_output_files_open(wpd_output_files *p, const wpd_cloud *cloud, const char *outdir,
                          wpd_error *err);

/* Removes every file of p not renamed into place, and frees p. */
void wpd_output_files_close(wpd_output_files *p);

/* The selection of a run's samples: res's (plain run), or with classes
 * (a run by class, res its merged result) the class groups' and the kept
 * points; labelled: write the sharp-feature labels. It borrows res's
 * per-file facts and reads its points from the runs while they are
 * written. */
wpd_selection wpd_output_selection(wpd_resample_result *res, wpd_class_result *classes,
                                   int labelled);

/* Writes the outputs of sel into files (finished under temporary names):
 * every rank its share where the selection allows (wpd_selection_shared),
 * else rank 0 alone; *writers gets how many ranks wrote. Every rank calls
 * it. Returns 0, or -1 with err set and no output left. */
int wpd_output_write(const wpd_selection *sel, wpd_cloud *cloud,
                     const wpd_selection_target *target, wpd_outfile *files, int *writers,
                     wpd_error *err);

/* Removes the output parts that ranks of runs killed outright left in
 * tmpdir (any output format, and output's own extension as written). */
void wpd_output_sweep_parts(const char *tmpdir, const char *output);

#endif
