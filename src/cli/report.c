#include "cli/report.h"

#include <stdio.h>
#include <stdlib.h>

#include "cli/resample_collection.h"
#include "common/json.h"

static void field_num(FILE *f, const char *key, double v, int comma)
{
    fprintf(f, "  \"%s\": ", key);
    wpd_json_number(f, v);
    fputs(comma ? ",\n" : "\n", f);
}

static void field_str(FILE *f, const char *key, const char *v)
{
    fprintf(f, "  \"%s\": ", key);
    if (v)
        wpd_json_string(f, v);
    else
        fputs("null", f);
    fputs(",\n", f);
}

static void write_inputs(FILE *f, const wpd_run_info *r)
{
    fputs("  \"inputs\": [", f);
    for (int i = 0; i < r->ninputs; i++) {
        if (i)
            fputs(", ", f);
        wpd_json_string(f, r->inputs[i]);
    }
    fputs("],\n", f);
}

static void write_options(FILE *f, const wpd_run_info *r)
{
    const wpd_params *p = r->params;
    fprintf(f, "  \"options\": {\"n\": %llu, \"lambda\": %.17g, \"voxel_frac\": %.17g, "
               "\"radius_estimate\": \"%s\", \"k\": %d, \"iterations\": %d, \"even_steps\": %d, "
               "\"smooth\": %s, \"sharp\": %s, "
               "\"seed\": %llu, \"mem_bytes\": %zu},\n",
            (unsigned long long)r->target, p->lambda, p->voxel_frac,
            p->radius_method == WPD_RADIUS_PAPER ? "paper" : "multiscale", p->k, p->iterations,
            p->even_iterations, p->smooth ? "true" : "false", p->sharp ? "true" : "false",
            (unsigned long long)p->seed, r->mem_bytes);
}

static void write_phases(FILE *f, const wpd_run_info *r)
{
    fputs("  \"seconds\": {", f);
    const char *names[] = {"load", "scan", "tile", "radius", "poisson", "exact", "smooth",
                           "write", "total"};
    const wpd_resample_timings *t = &r->run->time;
    const double v[] = {t->bounds, t->scan, t->tile, t->plan, t->poisson,
                        t->exact, t->smooth + t->merge, r->t_write, r->t_total};
    for (int i = 0; i < 9; i++) {
        fprintf(f, "%s\"%s\": ", i ? ", " : "", names[i]);
        wpd_json_number(f, v[i]);
    }
    fputs("},\n", f);
}

static void write_tiles(FILE *f, const wpd_run_info *info)
{
    const wpd_resample_result *r = info->run;
    double ratio = r->spill.disk_bytes ? (double)r->spill.raw_bytes / r->spill.disk_bytes : 0;
    fprintf(f, "  \"spill\": {\"points\": %llu, \"raw_bytes\": %llu, \"disk_bytes\": %llu, "
               "\"ratio\": ", (unsigned long long)r->spill.points,
            (unsigned long long)r->spill.raw_bytes, (unsigned long long)r->spill.disk_bytes);
    wpd_json_number(f, ratio);
    fprintf(f, ", \"work_file_bytes\": %llu", (unsigned long long)r->work_file_bytes);
    /* A cloud held in memory is one tile, reported as none: no spill. */
    int tiles = r->in_memory ? 0 : r->tiles;
    fprintf(f, "},\n  \"tiles\": {\"count\": %d, \"colours\": %d, \"largest_points\": %llu, "
               "\"boxes\": [", tiles, r->in_memory ? 0 : r->colours,
            (unsigned long long)(r->in_memory ? 0 : r->largest_tile));
    for (int t = 0; t < tiles; t++) {
        fputs(t ? ", {\"min\": [" : "{\"min\": [", f);
        for (int k = 0; k < 6; k++) {
            wpd_json_number(f, r->tile_box[6 * t + k]);
            fputs(k == 2 ? "], \"max\": [" : k == 5 ? "]}" : ", ", f);
        }
    }
    fputs("]},\n", f);
}

const char *wpd_class_role_name(wpd_class_role role)
{
    static const char *const names[] = {"rest", "drop", "keep", "count"};
    return names[role];
}

/* A run by class: the points of every class present, and each resampled
 * group's count and radius. */
static void write_classes(FILE *f, const wpd_class_result *c)
{
    fputs("  \"classes\": [", f);
    for (int i = 0; i < c->nlines; i++) {
        const wpd_class_line *l = &c->lines[i];
        fprintf(f, "%s{\"class\": %ld, \"role\": \"%s\", \"input_points\": %llu, "
                   "\"output_points\": %llu}", i ? ", " : "", l->cls,
                wpd_class_role_name(l->role), (unsigned long long)l->in,
                (unsigned long long)l->out);
    }
    fputs("],\n  \"class_groups\": [", f);
    for (int i = 0; i < c->ngroups; i++) {
        const wpd_class_group *g = &c->groups[i];
        fputs(i ? ", {\"class\": " : "{\"class\": ", f);
        if (g->cls < 0)
            fputs("null", f);
        else
            fprintf(f, "%ld", g->cls);
        fprintf(f, ", \"input_points\": %llu, \"target\": %llu, \"whole\": %s, "
                   "\"output_points\": %llu, \"radius\": ", (unsigned long long)g->points,
                (unsigned long long)g->target, g->whole ? "true" : "false",
                (unsigned long long)(g->whole ? g->points : g->run.count));
        wpd_json_number(f, g->whole ? 0 : g->run.radius);
        fputs("}", f);
    }
    fprintf(f, "],\n  \"dropped_by_class\": %llu,\n", (unsigned long long)c->dropped);
}

static void write_body(FILE *f, const wpd_run_info *r)
{
    const wpd_resample_result *run = r->run;
    fputs("{\n", f);
    write_inputs(f, r);
    field_str(f, "output", r->output);
    field_str(f, "per_input", r->per_input);
    fprintf(f, "  \"threads\": %d,\n", r->threads);
    write_options(f, r);
    fprintf(f, "  \"input_points\": %llu,\n  \"dropped_non_finite\": %llu,\n"
               "  \"output_points\": %zu,\n", (unsigned long long)run->input_points,
            (unsigned long long)r->dropped, run->count);
    field_num(f, "radius_estimate", run->radius_estimate, 1);
    field_num(f, "radius", run->radius, 1);
    fprintf(f, "  \"first_pass_points\": %zu,\n  \"poisson_points\": %zu,\n"
               "  \"poisson_passes\": %d,\n  \"resolution_rounds\": %d,\n"
               "  \"resolution_tiles\": %d,\n"
               "  \"exact_sweeps\": %d,\n  \"exact_rounds\": %d,\n"
               "  \"open_cells\": %zu,\n  \"pulled_to_surface\": %zu,\n"
               "  \"non_surface\": %zu,\n  \"isolated\": %zu,\n  \"guarded_moves\": %zu,\n",
            run->first_pass_count, run->poisson_count, run->passes, run->resolution_rounds,
            run->resolution_tiles,
            run->exact_sweeps, run->exact_rounds,
            run->open_cells, run->pulled_to_surface, run->non_surface, run->isolated,
            run->guarded_moves);
    write_phases(f, r);
    write_tiles(f, r);
    if (r->classes)
        write_classes(f, r->classes);
    else
        fputs("  \"classes\": null,\n  \"class_groups\": null,\n  \"dropped_by_class\": 0,\n", f);
    fprintf(f, "  \"peak_rss_bytes\": %lld,\n", (long long)r->peak_rss_kb * 1024);
    fprintf(f, "  \"records_cached\": %llu,\n", (unsigned long long)r->records_cached);
    fprintf(f, "  \"ranks\": %d,\n", r->ranks);
    fprintf(f, "  \"exchanged_bytes\": %llu,\n", (unsigned long long)r->exchanged_bytes);
    fprintf(f, "  \"writers\": %d,\n", r->writers);
    fputs("  \"collection\": ", f);
    if (r->collection)
        wpd_cli_collection_report(r->collection, f);
    else
        fputs("null", f);
    fputs(",\n", f);
    fprintf(f, "  \"metrics\": %s}\n", r->metrics_json ? r->metrics_json : "null\n");
}

int wpd_report_write(const char *path, const wpd_run_info *info, wpd_outfile *pending,
                     wpd_error *err)
{
    char *text = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&text, &len);
    if (!mem)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the report", path);
    write_body(mem, info);
    if (fclose(mem) != 0) {
        free(text);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the report", path);
    }
    int rc = wpd_outfile_open(pending, path, 1, err);
    if (rc == 0 && (rc = wpd_outfile_write(pending, text, len, err)) == 0)
        rc = wpd_outfile_finish(pending, err);
    if (rc)
        wpd_outfile_abort(pending);
    free(text);
    return rc;
}
