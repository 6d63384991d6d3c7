/* cmd_info.c - `wpd info FILE...`: what a file holds, as text or JSON. */
#include "cli/commands.h"
#include "common/json.h"
#include "common/outfile.h"
#include "common/printable.h"
#include "io/cloud.h"
#include "io/las/las.h"
#include "io/laz/laz.h"
#include "io/pass.h"

#include <getopt.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *usage_text =
    "usage: wpd info [--json] [--header-only] FILE...\n"
    "Prints each file's format, version, point format, point count, bounds,\n"
    "dimensions (name, type, byte offset) and VLRs (LAS) or elements and\n"
    "comments (PLY). Reads every point to report the finite count and the\n"
    "bounds of the points, unless --header-only. Text from the file is shown\n"
    "with bytes that are not printable ASCII as \\xNN. What the file bends in\n"
    "its format (and, with the points read, LAS header bounds or return counts\n"
    "that disagree with the points) is reported as warnings on stderr and, with\n"
    "--json, in each file's \"warnings\".\n"
    "  --json         one JSON document: {\"files\": [ ... ]}\n"
    "  --header-only  do not read the points\n";

typedef struct info_options {
    int json, header_only;
} info_options;

/* One lane's tally of the points it read. */
typedef struct info_lane {
    wpd_bounds box;
    uint64_t by_return[16];
} info_lane;

typedef struct info_scan {
    const wpd_header *h;
    info_lane *lanes;
} info_scan;

static int tally_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    info_scan *sc = arg;
    info_lane *l = &sc->lanes[pb->lane];
    wpd_bounds_add(&l->box, pb->batch->xyz, pb->batch->n);
    if (sc->h->format == WPD_FMT_LAS)
        wpd_las_tally_returns(sc->h, pb->batch->records, pb->batch->n, l->by_return);
    return 0;
}

/* Finite points, their bounds and (LAS) return numbers, from one pass over
 * the one-file cloud read (and, for LAZ, decoded) on every thread
 * (io/pass.h); *dropped: the points with non-finite coordinates. */
static int scan_points(wpd_cloud *cloud, wpd_bounds *b, uint64_t by_return[16],
                       uint64_t *dropped, wpd_error *err)
{
    int threads = omp_get_max_threads();
    info_scan sc = {wpd_cloud_header(cloud, 0), calloc((size_t)threads, sizeof *sc.lanes)};
    if (!sc.lanes)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int t = 0; t < threads; t++)
        wpd_bounds_reset(&sc.lanes[t].box);
    wpd_pass pass = {.cloud = cloud, .threads = threads, .lane = tally_lane, .arg = &sc};
    int rc = wpd_pass_run(&pass, err);
    wpd_bounds_reset(b);
    for (int t = 0; t < threads; t++) {
        wpd_bounds_union(b, &sc.lanes[t].box);
        for (int k = 0; k < 16; k++)
            by_return[k] += sc.lanes[t].by_return[k];
    }
    *dropped = wpd_cloud_dropped(cloud);
    free(sc.lanes);
    return rc;
}

static const char *ply_encoding_name(wpd_ply_encoding e)
{
    return e == WPD_PLY_ASCII ? "ascii"
           : e == WPD_PLY_BINARY_LE ? "binary_little_endian" : "binary_big_endian";
}

static void text_bounds(const char *label, const double *lo, const double *hi)
{
    printf("  %-17s x [%.6f, %.6f]  y [%.6f, %.6f]  z [%.6f, %.6f]\n", label, lo[0], hi[0],
           lo[1], hi[1], lo[2], hi[2]);
}

static void text_vlrs(const char *label, const wpd_vlr *v, uint32_t n)
{
    printf("  %s: %u\n", label, n);
    for (uint32_t i = 0; i < n; i++) {
        char user[WPD_PRINTABLE_SIZE(16)], text[WPD_PRINTABLE_SIZE(32)];
        printf("    %-16s %5u  %8llu bytes  %s\n",
               wpd_printable(user, sizeof user, v[i].user_id), v[i].record_id,
               (unsigned long long)v[i].length,
               wpd_printable(text, sizeof text, v[i].description));
    }
}

static void text_schema(const wpd_schema *s)
{
    printf("  dimensions: %u (record %u bytes)\n", s->ndims, s->record_size);
    for (uint32_t i = 0; i < s->ndims; i++) {
        const wpd_dim *d = &s->dims[i];
        printf("    %-28s %-7s offset %3u", d->name, wpd_type_name(d->type), d->offset);
        if (d->bit_count)
            printf("  bits %u..%u", d->bit_shift, d->bit_shift + d->bit_count - 1);
        if (d->scaled)
            printf("  * %.17g + %.17g", d->scale, d->add);
        putchar('\n');
    }
}

/* The LASzip VLR of a LAZ file: compressor, chunking, items. */
static void text_laz(const wpd_laz_info *z)
{
    printf("  compressor:       %s (%u), LASzip %u.%ur%u\n", wpd_laz_compressor_name(z->compressor),
           z->compressor, z->version_major, z->version_minor, z->version_revision);
    if (z->compressor == 1)
        printf("  chunks:           none (one stream)\n");
    else if (z->chunk_size == UINT32_MAX || z->chunk_size == 0)
        printf("  chunks:           variable size, %llu in the chunk table\n",
               (unsigned long long)z->chunks);
    else
        printf("  chunks:           %u points each, %llu in the chunk table\n", z->chunk_size,
               (unsigned long long)z->chunks);
    printf("  items:           ");
    for (uint16_t i = 0; i < z->nitems; i++)
        printf(" %s%s (%u bytes, v%u)", i ? "+ " : "", wpd_laz_item_name(z->items[i].type),
               z->items[i].size, z->items[i].version);
    putchar('\n');
}

static void json_laz(const wpd_laz_info *z)
{
    printf(", \"laz\": {\"compressor\": %u, \"compressor_name\": \"%s\", \"laszip_version\": "
           "\"%u.%ur%u\", \"chunk_size\": %u, \"chunks\": %llu, \"items\": [",
           z->compressor, wpd_laz_compressor_name(z->compressor), z->version_major,
           z->version_minor, z->version_revision, z->chunk_size, (unsigned long long)z->chunks);
    for (uint16_t i = 0; i < z->nitems; i++)
        printf("%s{\"type\": \"%s\", \"size\": %u, \"version\": %u}", i ? ", " : "",
               wpd_laz_item_name(z->items[i].type), z->items[i].size, z->items[i].version);
    fputs("]}", stdout);
}

static void json_copc(const wpd_las_info *l)
{
    printf(", \"copc\": %s", l->copc ? "true" : "false");
}

static void print_text(const wpd_header *h, const wpd_bounds *b, uint64_t dropped)
{
    printf("%s\n", h->path);
    if (h->format == WPD_FMT_LAS) {
        const wpd_las_info *l = &h->las;
        printf("  format:           %s %u.%u, point format %u, %u-byte records (%u extra bytes)\n",
               l->laz.compressed ? "LAZ" : "LAS", l->version_major, l->version_minor, l->pdrf,
               l->record_length, l->extra_bytes);
        if (l->laz.compressed)
            text_laz(&l->laz);
        if (l->copc)
            printf("  COPC:             yes; its info VLR and hierarchy EVLR index this file's "
                   "chunks and are not carried over\n");
    } else {
        printf("  format:           PLY %s\n", ply_encoding_name(h->ply.encoding));
    }
    printf("  points:           %llu\n", (unsigned long long)h->point_count);
    if (b)
        printf("  finite points:    %llu (%llu dropped: non-finite coordinates)\n",
               (unsigned long long)b->count, (unsigned long long)dropped);
    if (h->format == WPD_FMT_LAS) {
        const wpd_las_info *l = &h->las;
        printf("  scale:            %.17g %.17g %.17g\n", l->scale[0], l->scale[1], l->scale[2]);
        printf("  offset:           %.17g %.17g %.17g\n", l->offset[0], l->offset[1], l->offset[2]);
        text_bounds("bounds (header):", l->min, l->max);
    }
    if (b && b->count)
        text_bounds("bounds (points):", b->min, b->max);
    text_schema(&h->schema);
    if (h->format == WPD_FMT_LAS) {
        text_vlrs("vlrs", h->las.vlrs, h->las.nvlr);
        text_vlrs("evlrs", h->las.evlrs, h->las.nevlr);
        char system[WPD_PRINTABLE_SIZE(32)], software[WPD_PRINTABLE_SIZE(32)];
        printf("  system id:        %s\n  software:         %s\n",
               wpd_printable(system, sizeof system, h->las.system_id),
               wpd_printable(software, sizeof software, h->las.software));
    } else {
        for (uint32_t i = 0; i < h->ply.nelements; i++)
            printf("  element:          %s %llu (%u properties%s)\n", h->ply.elements[i].name,
                   (unsigned long long)h->ply.elements[i].count, h->ply.elements[i].nprops,
                   h->ply.elements[i].has_lists ? ", lists" : "");
        for (uint32_t i = 0; i < h->ply.ncomments; i++)
            printf("  comment:          %s\n", h->ply.comments[i]);
        for (uint32_t i = 0; i < h->ply.nobj_info; i++)
            printf("  obj_info:         %s\n", h->ply.obj_info[i]);
    }
}

static void json_triple(const char *key, const double *v)
{
    printf("\"%s\": [", key);
    for (int k = 0; k < 3; k++) {
        wpd_json_number(stdout, v[k]);
        fputs(k < 2 ? ", " : "]", stdout);
    }
}

static void json_bounds(const char *key, const double *lo, const double *hi)
{
    printf(", \"%s\": {", key);
    json_triple("min", lo);
    fputs(", ", stdout);
    json_triple("max", hi);
    putchar('}');
}

static void json_vlrs(const char *key, const wpd_vlr *v, uint32_t n)
{
    printf(", \"%s\": [", key);
    for (uint32_t i = 0; i < n; i++) {
        fputs(i ? ", {\"user_id\": " : "{\"user_id\": ", stdout);
        wpd_json_string(stdout, v[i].user_id);
        printf(", \"record_id\": %u, \"length\": %llu, \"description\": ", v[i].record_id,
               (unsigned long long)v[i].length);
        wpd_json_string(stdout, v[i].description);
        putchar('}');
    }
    putchar(']');
}

static void json_schema(const wpd_schema *s)
{
    printf(", \"record_size\": %u, \"dimensions\": [", s->record_size);
    for (uint32_t i = 0; i < s->ndims; i++) {
        const wpd_dim *d = &s->dims[i];
        fputs(i ? ", {\"name\": " : "{\"name\": ", stdout);
        wpd_json_string(stdout, d->name);
        printf(", \"type\": \"%s\", \"offset\": %u", wpd_type_name(d->type), d->offset);
        if (d->bit_count)
            printf(", \"bit_shift\": %u, \"bit_count\": %u", d->bit_shift, d->bit_count);
        if (d->scaled) {
            fputs(", \"scale\": ", stdout);
            wpd_json_number(stdout, d->scale);
            fputs(", \"add\": ", stdout);
            wpd_json_number(stdout, d->add);
        }
        putchar('}');
    }
    putchar(']');
}

static void json_strings(const char *key, char *const *s, uint32_t n)
{
    printf(", \"%s\": [", key);
    for (uint32_t i = 0; i < n; i++) {
        if (i)
            fputs(", ", stdout);
        wpd_json_string(stdout, s[i]);
    }
    putchar(']');
}

static void json_warnings(const wpd_warnings *w)
{
    fputs(", \"warnings\": [", stdout);
    for (uint32_t i = 0; i < w->n; i++) {
        if (i)
            fputs(", ", stdout);
        wpd_json_string(stdout, w->line[i]);
    }
    putchar(']');
}

static void print_json(const wpd_header *h, const wpd_bounds *b, uint64_t dropped,
                       const wpd_warnings *w, int first)
{
    fputs(first ? "\n  {\"path\": " : ",\n  {\"path\": ", stdout);
    wpd_json_string(stdout, h->path);
    printf(", \"format\": \"%s\", \"point_count\": %llu",
           h->format != WPD_FMT_LAS ? "PLY" : h->las.laz.compressed ? "LAZ" : "LAS",
           (unsigned long long)h->point_count);
    if (b) {
        printf(", \"finite_point_count\": %llu, \"dropped_non_finite\": %llu",
               (unsigned long long)b->count, (unsigned long long)dropped);
        if (b->count)
            json_bounds("bounds", b->min, b->max);
    }
    if (h->format == WPD_FMT_LAS) {
        const wpd_las_info *l = &h->las;
        printf(", \"version\": \"%u.%u\", \"point_format\": %u, \"extra_bytes\": %u",
               l->version_major, l->version_minor, l->pdrf, l->extra_bytes);
        json_bounds("header_bounds", l->min, l->max);
        fputs(", ", stdout);
        json_triple("scale", l->scale);
        fputs(", ", stdout);
        json_triple("offset", l->offset);
        json_vlrs("vlrs", l->vlrs, l->nvlr);
        json_vlrs("evlrs", l->evlrs, l->nevlr);
        if (l->laz.compressed)
            json_laz(&l->laz);
        json_copc(l);
    } else {
        printf(", \"encoding\": \"%s\", \"elements\": [", ply_encoding_name(h->ply.encoding));
        for (uint32_t i = 0; i < h->ply.nelements; i++) {
            fputs(i ? ", {\"name\": " : "{\"name\": ", stdout);
            wpd_json_string(stdout, h->ply.elements[i].name);
            printf(", \"count\": %llu}", (unsigned long long)h->ply.elements[i].count);
        }
        putchar(']');
        json_strings("comments", h->ply.comments, h->ply.ncomments);
        json_strings("obj_info", h->ply.obj_info, h->ply.nobj_info);
    }
    json_schema(&h->schema);
    json_warnings(w);
    putchar('}');
}

static int info_one(const char *path, const info_options *opt, int first, wpd_error *err)
{
    wpd_cloud *cloud = wpd_cloud_open(&path, 1, err);
    if (!cloud)
        return -1;
    const wpd_header *h = wpd_cloud_header(cloud, 0);
    wpd_bounds b;
    uint64_t by_return[16] = {0};
    uint64_t dropped = 0;
    int rc = opt->header_only ? 0 : scan_points(cloud, &b, by_return, &dropped, err);
    if (rc) /* what is odd about the file may explain why its points cannot be read */
        wpd_warnings_print(stderr, "info", &h->warnings);
    if (rc == 0) {
        const wpd_bounds *pb = opt->header_only ? NULL : &b;
        wpd_warnings w = h->warnings;
        if (pb)
            wpd_las_check_header_against_points(h, pb, by_return, &w);
        wpd_warnings_print(stderr, "info", &w);
        if (opt->json)
            print_json(h, pb, dropped, &w, first);
        else
            print_text(h, pb, dropped);
    }
    wpd_cloud_close(cloud);
    return rc;
}

int wpd_cmd_info(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"json", no_argument, 0, 'j'}, {"header-only", no_argument, 0, 'H'},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    info_options opt = {0};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        if (c == 'j') opt.json = 1;
        else if (c == 'H') opt.header_only = 1;
        else if (c == 'h') { fputs(usage_text, stdout); return 0; }
        else { fputs(usage_text, stderr); return WPD_E_USAGE; }
    }
    if (optind >= argc) {
        fputs(usage_text, stderr);
        return WPD_E_USAGE;
    }
    int status = 0;
    if (opt.json)
        fputs("{\"files\": [", stdout);
    for (int i = optind, shown = 0; i < argc; i++) {
        wpd_error err = {0};
        if (info_one(argv[i], &opt, shown == 0, &err) == 0)
            shown++;
        else if (!status)
            status = wpd_report_error("info", &err);
        else
            wpd_report_error("info", &err);
    }
    if (opt.json)
        fputs("\n]}\n", stdout);
    /* What info prints is its product: losing it (a full disk) fails. */
    wpd_error err = {0};
    if (wpd_stdout_flush(&err)) {
        int code = wpd_report_error("info", &err);
        status = status ? status : code;
    }
    return status;
}
