/* preview_read.c - one input of `wpd preview` (a panel): its buffers and
 * its two streaming passes, pass 1 for bounds, count, colour depth and
 * view extents, pass 2 drawing into the z-buffer and feeding the spacing
 * sample. Nothing per point is kept beyond the sample.
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DRAW_PER_PIXEL 64         /* points per view pixel worth drawing */

void preview_panel_free(panel *p)
{
    wpd_cloud_close(p->cloud);
    free(p->depth);
    free(p->z);
    free(p->rgb);
    free(p->sample.xyz);
    free(p->spacing);
    free(p->label);
    memset(p, 0, sizeof *p);
}

void preview_crop_batch(const panel *p, wpd_batch *b)
{
    const wpd_preview_options *o = p->opt;
    if (!o || !o->crop)
        return;
    size_t kept = 0, rs = b->record_size;
    for (size_t i = 0; i < b->n; i++) {
        const double *q = b->xyz + 3 * i;
        if (!(q[0] >= o->crop_lo[0] && q[0] < o->crop_hi[0] && q[1] >= o->crop_lo[1] &&
              q[1] < o->crop_hi[1]))
            continue;
        if (kept != i) {
            memmove(b->xyz + 3 * kept, q, 3 * sizeof *q);
            memmove(b->records + kept * rs, b->records + i * rs, rs);
        }
        kept++;
    }
    b->n = kept;
}

/* The label dimension of p's file (-1 without --label). Returns 0, or -1
 * with err set when the file has no such dimension. */
static int find_label(panel *p, const wpd_schema *s, wpd_error *err)
{
    p->label_dim = -1;
    if (!p->opt || !p->opt->label)
        return 0;
    if ((p->label_dim = wpd_schema_find(s, p->opt->label)) < 0)
        return wpd_fail(err, WPD_E_USAGE, "%s: no dimension %s to colour by", p->path,
                        p->opt->label);
    return 0;
}

/* Pass 1: bounds, count, the largest colour value and (track_views) the
 * screen extents of the candidate views. */
int preview_scan_pass(panel *p, wpd_batch *b, wpd_error *err)
{
    const wpd_schema *s = &wpd_cloud_header(p->cloud, 0)->schema;
    int has_rgb = preview_find_colour_dims(p);
    if (find_label(p, s, err))
        return -1;
    wpd_bounds bb;
    wpd_bounds_reset(&bb);
    double cmax = 0;
    for (int a = 0; a < AZIMUTHS; a++)
        for (int k = 0; k < 2; k++)
            p->ext_lo[a][k] = INFINITY, p->ext_hi[a][k] = -INFINITY;
    long got;
    while ((got = wpd_cloud_read(p->cloud, b, NULL, err)) > 0) {
        preview_crop_batch(p, b);
        wpd_bounds_add(&bb, b->xyz, b->n);
        if (p->track_views)
            preview_track_extents(p, b);
        for (int c = 0; has_rgb && c < 3; c++)
            cmax = fmax(cmax, preview_colour_max(&s->dims[p->rgb_dim[c]], b));
    }
    if (got < 0)
        return -1;
    if (bb.count == 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates%s", p->path,
                        p->opt && p->opt->crop ? " in the crop" : "");
    memcpy(p->lo, bb.min, sizeof p->lo);
    memcpy(p->hi, bb.max, sizeof p->hi);
    p->info.points = bb.count;
    preview_colour_depth(p, has_rgb, cmax);
    return wpd_cloud_rewind(p->cloud, err);
}

int preview_panel_alloc(panel *p, const view *v, int by_rgb, wpd_error *err)
{
    size_t npix = (size_t)v->w * (size_t)v->h;
    p->depth = malloc(npix * sizeof *p->depth);
    p->z = malloc(npix * sizeof *p->z);
    if (by_rgb)
        p->rgb = malloc(npix * 3);
    if (p->label_dim >= 0 && !(p->label = malloc(npix)))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a %d x %d picture", p->path,
                        v->w, v->h);
    p->sample.cap = WPD_PREVIEW_SAMPLE_MAX;
    p->sample.xyz = malloc(p->sample.cap * 3 * sizeof *p->sample.xyz);
    if (!p->depth || !p->z || (by_rgb && !p->rgb) || !p->sample.xyz)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a %d x %d picture", p->path,
                        v->w, v->h);
    for (size_t i = 0; i < npix; i++)
        p->depth[i] = INFINITY;
    return 0;
}

/* Pass 2: every stride-th point into the z-buffer, every point offered to
 * the spacing sample. */
int preview_draw_pass(panel *p, const view *v, const double origin[3], wpd_batch *b,
                      wpd_error *err)
{
    const wpd_schema *s = &wpd_cloud_header(p->cloud, 0)->schema;
    uint64_t limit = (uint64_t)DRAW_PER_PIXEL * (uint64_t)v->w * (uint64_t)v->h;
    p->info.stride = p->info.points > limit ? (p->info.points + limit - 1) / limit : 1;
    uint64_t ordinal = 0;
    long got;
    while ((got = wpd_cloud_read(p->cloud, b, NULL, err)) > 0) {
        preview_crop_batch(p, b);
        for (size_t i = 0; i < b->n; i++, ordinal++) {
            const double *a = b->xyz + 3 * i;
            double q[3] = {a[0] - origin[0], a[1] - origin[1], a[2] - origin[2]};
            preview_sample_add(&p->sample, q);
            if (ordinal % p->info.stride == 0) {
                const uint8_t *rec = b->records + i * b->record_size;
                preview_draw_point(p, v, q, rec, s);
                p->info.drawn++;
                p->info.labelled += p->label && wpd_dim_get(&s->dims[p->label_dim], rec) != 0;
            }
        }
    }
    return got < 0 ? -1 : 0;
}
