/* edges_write.c - `wpd edges -o OUT` (see edges_write.h): the cloud read
 * again, each batch laid out for the output with the label field. */
#include "tools/edges/edges_write.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "common/outfile.h"
#include "io/layout.h"
#include "io/writer.h"

int wpd_edges_check_output(const char *out, char *const *inputs, int n, int overwrite,
                           wpd_error *err)
{
    struct stat st;
    if (wpd_format_from_name(out) == WPD_FMT_NONE)
        return wpd_fail(err, WPD_E_USAGE, "%s: output must end in .las or .ply", out);
    if (wpd_path_is_one_of(out, inputs, n))
        return wpd_fail(err, WPD_E_USAGE, "%s: output is also an input", out);
    if (!overwrite && stat(out, &st) == 0)
        return wpd_fail(err, WPD_E_USAGE, "%s: output exists (use --force to replace it)", out);
    return 0;
}

/* The output header and map for cloud's points with the label field d. */
static int plan(wpd_cloud *cloud, const char *out, wpd_header *h, wpd_layout_map *map, int *d,
                wpd_error *err)
{
    wpd_bounds b;
    if (wpd_cloud_bounds(cloud, &b, err))
        return -1;
    if (wpd_layout_plan(wpd_cloud_header(cloud, 0), &b, wpd_format_from_name(out), h, map, err))
        return -1;
    int replaced;
    if ((*d = wpd_layout_add_label(h, "edge", "sharp feature (wpd edges)", &replaced, err)) < 0) {
        wpd_header_free(h);
        return -1;
    }
    if (replaced)
        fprintf(stderr, "wpd edges: notice: the input's dimension edge is replaced by the "
                "labels\n");
    return 0;
}

/* Streams the points through the map into w, the labels set. */
static int copy_points(wpd_cloud *cloud, const wpd_header *h, const wpd_layout_map *map, int d,
                       const uint8_t *edge, size_t n, wpd_writer *w, wpd_error *err)
{
    const wpd_header *in = wpd_cloud_header(cloud, 0);
    wpd_batch src, dst;
    memset(&src, 0, sizeof src);
    memset(&dst, 0, sizeof dst);
    int rc = wpd_batch_init(&src, 65536, in->schema.record_size) ||
                     wpd_batch_init(&dst, 65536, h->schema.record_size)
                 ? wpd_fail(err, WPD_E_MEMORY, "out of memory for the write buffers")
                 : wpd_cloud_rewind(cloud, err);
    size_t done = 0;
    long got = 0;
    while (rc == 0 && (got = wpd_cloud_read(cloud, &src, NULL, err)) > 0) {
        if (done + src.n > n) {
            rc = wpd_fail(err, WPD_E_INPUT, "%s: the input changed while being read", in->path);
            break;
        }
        wpd_layout_apply(map, &in->schema, &h->schema, &src, &dst);
        wpd_layout_set_labels(&h->schema.dims[d], &dst, edge + done);
        done += src.n;
        rc = wpd_writer_write(w, &dst, err);
    }
    if (rc == 0 && got < 0)
        rc = -1;
    if (rc == 0 && done != n)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the input changed while being read", in->path);
    wpd_batch_free(&src);
    wpd_batch_free(&dst);
    return rc;
}

int wpd_edges_write(wpd_cloud *cloud, const uint8_t *edge, size_t n, const char *out,
                    int overwrite, wpd_error *err)
{
    wpd_header h;
    wpd_layout_map map;
    int d;
    if (plan(cloud, out, &h, &map, &d, err))
        return -1;
    wpd_write_options wo = {.overwrite = overwrite};
    wpd_writer *w = wpd_writer_open(out, &h, &wo, err);
    int rc = w ? copy_points(cloud, &h, &map, d, edge, n, w, err) : -1;
    if (rc == 0) {
        rc = wpd_writer_close(w, err);
        w = NULL;
    }
    wpd_writer_abort(w);
    wpd_header_free(&h);
    return rc;
}
