/* cmd_convert.c - `wpd convert IN... OUT`: streaming format conversion. */
#include "cli/commands.h"
#include "common/outfile.h"
#include "io/cloud.h"
#include "io/layout.h"
#include "io/writer.h"
#include "resample/budget.h"
#include "io/pass.h"

#include <getopt.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

static const char *usage_text =
    "usage: wpd convert [--ascii] [--force] IN... OUT\n"
    "Streams the points of IN (several inputs are read as one cloud) into OUT,\n"
    "whose format comes from its extension (.las, .laz or .ply). Every attribute is\n"
    "kept: LAS to LAS keeps version, point format and VLRs; LAS to PLY writes\n"
    "x y z as double and every LAS dimension as a named property; PLY to LAS\n"
    "maps colour, intensity and classification and keeps the rest as extra\n"
    "bytes. Points with non-finite coordinates are dropped with a warning.\n"
    "  --ascii   write ascii PLY (default: binary little-endian)\n"
    "  --force   replace OUT if it exists\n";

/* The writer's side of the pass: batches in reading order. */
typedef struct convert_stream {
    const wpd_header *in, *out;
    const wpd_layout_map *map;
    wpd_writer *w;
    wpd_batch dst;
} convert_stream;

static int write_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    convert_stream *cs = arg;
    wpd_layout_apply(cs->map, &cs->in->schema, &cs->out->schema, pb->batch, &cs->dst);
    return wpd_writer_write(cs->w, &cs->dst, err);
}

/* Every point to the writer: read (and, for LAZ, decoded) on every thread
 * an ordered pass has (io/pass.h), written in order on one. */
static int stream_points(wpd_cloud *cloud, const wpd_header *in, const wpd_header *out,
                         const wpd_layout_map *map, wpd_writer *w, wpd_error *err)
{
    convert_stream cs = {in, out, map, w, {0}};
    if (wpd_batch_init(&cs.dst, WPD_BATCH_POINTS, out->schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_pass pass = {.cloud = cloud, .threads = omp_get_max_threads(), .commit = write_commit,
                     .arg = &cs};
    int rc = wpd_cloud_rewind(cloud, err) ? -1 : wpd_pass_run(&pass, err);
    wpd_batch_free(&cs.dst);
    return rc;
}

static int convert(char **inputs, int n, const char *output, wpd_write_options *wopt,
                   wpd_error *err)
{
    wpd_format fmt = wpd_format_from_name(output);
    if (fmt == WPD_FMT_NONE)
        return wpd_fail(err, WPD_E_USAGE, "%s: output must end in .las, .laz or .ply", output);
    if (wpd_path_is_one_of(output, inputs, n))
        return wpd_fail(err, WPD_E_USAGE, "%s: output is also an input", output);
    wpd_cloud *cloud = wpd_cloud_open((const char *const *)inputs, n, err);
    if (!cloud)
        return -1;
    wpd_cloud_print_warnings(cloud, "convert", stderr);
    const wpd_header *in = wpd_cloud_header(cloud, 0);
    wpd_bounds bounds = {0};
    /* LAS output from PLY needs the bounds to choose scale and offset. */
    int rc = in->format != fmt ? wpd_cloud_bounds(cloud, &bounds, err) : 0;
    wpd_header out;
    wpd_layout_map map;
    if (rc == 0 && (rc = wpd_layout_plan(in, &bounds, fmt, &out, &map, err)) == 0) {
        wpd_writer *w = wpd_writer_open(output, &out, wopt, err);
        rc = w ? stream_points(cloud, in, &out, &map, w, err) : -1;
        uint64_t written = w ? wpd_writer_count(w) : 0;
        if (w && rc == 0)
            rc = wpd_writer_close(w, err);
        else
            wpd_writer_abort(w);
        if (rc == 0) {
            if (wpd_cloud_dropped(cloud))
                fprintf(stderr, "wpd convert: warning: %llu points with non-finite coordinates "
                        "dropped\n", (unsigned long long)wpd_cloud_dropped(cloud));
            printf("wrote %llu points to %s\n", (unsigned long long)written, output);
            /* OUT is in place and complete; a lost summary still fails. */
            rc = wpd_stdout_flush(err);
        }
        wpd_header_free(&out);
    }
    wpd_cloud_close(cloud);
    return rc;
}

int wpd_cmd_convert(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"ascii", no_argument, 0, 'a'}, {"force", no_argument, 0, 'f'},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    wpd_write_options wopt = {0};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "hf", longopts, NULL)) != -1) {
        if (c == 'a') wopt.ply_ascii = 1;
        else if (c == 'f') wopt.overwrite = 1;
        else if (c == 'h') { fputs(usage_text, stdout); return 0; }
        else { fputs(usage_text, stderr); return WPD_E_USAGE; }
    }
    if (argc - optind < 2) {
        fputs(usage_text, stderr);
        return WPD_E_USAGE;
    }
    wpd_error err = {0};
    if (convert(argv + optind, argc - optind - 1, argv[argc - 1], &wopt, &err))
        return wpd_report_error("convert", &err);
    return 0;
}
