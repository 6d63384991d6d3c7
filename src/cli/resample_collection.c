/* resample_collection.c - `wpd resample`'s collections from the command
 * line (resample_collection.h). */
#include "cli/resample_collection.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/json.h"
#include "io/append.h"

int wpd_cli_collection_init(wpd_cli_collection *cc, const char *outdir, const char *output,
                            const wpd_params *p, const wpd_class_args *classes, double spacing,
                            int rebuild, int skip_existing, const wpd_par *par, wpd_error *err)
{
    memset(cc, 0, sizeof *cc);
    if (wpd_collection_locate(&cc->c, outdir, output, err))
        return -1;
    wpd_coll_options *o = &cc->req.opt;
    o->lambda = p->lambda, o->voxel_frac = p->voxel_frac, o->radius_method = p->radius_method;
    o->k = p->k, o->iterations = p->iterations, o->even_steps = p->even_iterations;
    o->smooth = p->smooth, o->sharp = p->sharp, o->seed = p->seed;
    o->drop = wpd_coll_class_list(classes->drop);
    o->keep = wpd_coll_class_list(classes->keep);
    o->class_field = strdup(classes->field ? classes->field : "");
    if (!o->drop || !o->keep || !o->class_field)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    cc->req.keep = classes->keep;
    cc->req.spacing = spacing;
    cc->req.rebuild = rebuild;
    cc->req.skip_existing = skip_existing;
    cc->req.par = par;
    return 0;
}

void wpd_cli_collection_free(wpd_cli_collection *cc)
{
    wpd_coll_options_free(&cc->req.opt);
    wpd_night_free(&cc->night);
    wpd_collection_free(&cc->c);
}

int wpd_cli_collection_recover(wpd_cli_collection *cc, int quiet, wpd_error *err)
{
    int said = 0;
    if (wpd_collection_recover(&cc->c, &said, err))
        return -1;
    if (said && !quiet)
        fprintf(stderr, "wpd resample: %s: %s\n", cc->c.label,
                said == 1 ? "completed the night interrupted after its commit"
                          : "rolled back an unfinished night");
    if (wpd_collection_mark(&cc->c, err))
        return -1;
    cc->marked = 1;
    return 0;
}

/* --append's OUT, as a path. */
static void append_path(const wpd_cli_collection *cc, char *out, size_t size)
{
    snprintf(out, size, "%s/%s", cc->c.dir, cc->c.append);
}

int wpd_cli_collection_plan(wpd_cli_collection *cc, char **inputs, int ninputs, int overwrite,
                            wpd_error *err)
{
    if (wpd_collection_plan(&cc->c, &cc->req, inputs, ninputs, &cc->night, err))
        return -1;
    cc->planned = 1;
    if (!cc->c.append[0] || wpd_par_rank(cc->req.par) != 0)
        return 0;
    struct stat st;
    char out[1400];
    append_path(cc, out, sizeof out);
    int exists = stat(out, &st) == 0;
    if (!cc->night.later && exists && !overwrite && !cc->req.rebuild)
        return wpd_fail(err, WPD_E_USAGE, "%s: exists but is no collection (no %s): "
                        "--rebuild makes one of it from its inputs", cc->c.label, cc->c.state);
    return cc->night.later && cc->night.nnew ? wpd_append_check(out, err) : 0;
}

void wpd_cli_collection_options(const wpd_cli_collection *cc, wpd_resample_options *ro)
{
    const wpd_night *n = &cc->night;
    if (n->later || cc->req.spacing > 0) {
        ro->fixed_radius = n->radius;
        ro->density_factor = n->factor;
    }
    ro->fixed_xyz = n->fixed;
    ro->nfixed = n->nfixed;
}

/* --append on a later night: OUT's records and the night's (files[0],
 * written under OUT's temporary name) as one new file in their place;
 * *first: OUT's records before. */
static int append_night(wpd_cli_collection *cc, wpd_outfile *files, uint64_t *first,
                        wpd_error *err)
{
    char out[1400];
    uint64_t added = 0;
    append_path(cc, out, sizeof out);
    wpd_outfile joined;
    if (wpd_outfile_open(&joined, files[0].final_path, 1, err))
        return -1;
    if (wpd_append_files(out, files[0].temp_path, &joined, first, &added, err) ||
        wpd_outfile_finish(&joined, err)) {
        wpd_outfile_abort(&joined);
        return -1;
    }
    wpd_outfile_abort(&files[0]); /* the night's samples alone */
    files[0] = joined;
    return 0;
}

/* A first night's radius and density factor: --spacing's (f 1), or the
 * run's final radius and its count over the Poisson pass's. */
static int first_night_figures(const wpd_cli_collection *cc, const wpd_resample_result *res,
                               const wpd_class_result *classes, double *r, double *f,
                               wpd_error *err)
{
    if (cc->req.spacing > 0) {
        *r = cc->req.spacing, *f = 1;
        return 0;
    }
    const wpd_resample_result *run = classes && classes->ngroups ? &classes->groups[0].run : res;
    int whole = classes && classes->ngroups && classes->groups[0].whole;
    if (whole || !(run->radius > 0) || run->poisson_count == 0 || run->count == 0)
        return wpd_fail(err, WPD_E_USAGE, "%s: -n kept every point: a collection needs a "
                        "spacing (give a smaller -n, or --spacing D)", cc->c.label);
    *r = run->radius;
    *f = fmin(1, (double)run->count / (double)run->poisson_count);
    return 0;
}

int wpd_cli_collection_record(wpd_cli_collection *cc, const wpd_resample_result *res,
                              const wpd_class_result *classes, wpd_outfile *files, int n,
                              wpd_error *err)
{
    wpd_night_result nr = {0};
    nr.points = res->file_samples;
    nr.bounds = res->file_bounds;
    nr.files = files;
    nr.nfiles = n;
    if (!cc->night.later &&
        first_night_figures(cc, res, classes, &nr.radius, &nr.factor, err))
        return -1;
    if (cc->night.later && cc->c.append[0] && append_night(cc, files, &nr.first, err))
        return -1;
    return wpd_collection_record(&cc->c, &cc->req, &cc->night, &nr, err);
}

void wpd_cli_collection_print(const wpd_cli_collection *cc, size_t written,
                              unsigned long long target, const char *count_text)
{
    const wpd_night *n = &cc->night;
    printf("  collection %s, night %d: %d new input%s", cc->c.label, n->number, n->nnew,
           n->nnew == 1 ? "" : "s");
    if (n->skipped)
        printf(", %d already in it (skipped)", n->skipped);
    printf(", radius %.6g, density factor %.6g", cc->c.radius, cc->c.factor);
    if (n->later)
        printf(", %zu samples of earlier nights fixed (from %d output%s)", n->nfixed,
               n->outputs_read, n->outputs_read == 1 ? "" : "s");
    printf("\n");
    if (n->later && count_text)
        printf("  density wins over the count on a later night: wrote %zu points; -n %s of "
               "the night's points would be %llu\n", written, count_text, target);
}

void wpd_cli_collection_report(const wpd_cli_collection *cc, FILE *f)
{
    const wpd_night *n = &cc->night;
    fputs("{\"state\": ", f);
    wpd_json_string(f, cc->c.state);
    fprintf(f, ", \"night\": %d, \"later\": %s, \"new_inputs\": %d, \"skipped_inputs\": %d, "
               "\"radius\": ", n->number, n->later ? "true" : "false", n->nnew, n->skipped);
    wpd_json_number(f, cc->c.radius);
    fputs(", \"density_factor\": ", f);
    wpd_json_number(f, cc->c.factor);
    fprintf(f, ", \"spacing\": %s, \"fixed_samples\": %zu, \"outputs_read\": %d}",
            cc->c.spacing ? "true" : "false", n->nfixed, n->outputs_read);
}
