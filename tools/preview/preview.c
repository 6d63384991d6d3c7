/* preview.c - PNG pictures of point clouds (see preview.h for the view,
 * colours, spacing histograms and the memory bound): the public API. It
 * checks the size, lays out the panels, runs both passes over the inputs,
 * paints the picture and writes the file; the parts are listed in
 * preview_internal.h.
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/outfile.h"

#define BATCH_POINTS 65536

static const uint8_t background[3] = {246, 246, 242};

void wpd_preview_defaults(wpd_preview_options *opt)
{
    memset(opt, 0, sizeof *opt);
    opt->width = WPD_PREVIEW_DEFAULT_WIDTH;
    opt->height = WPD_PREVIEW_DEFAULT_HEIGHT;
}

void wpd_preview_image_free(wpd_preview_image *img)
{
    free(img->rgb);
    memset(img, 0, sizeof *img);
}

static int check_size(const wpd_preview_options *opt, int n, wpd_error *err)
{
    if (n < 1 || n > 2)
        return wpd_fail(err, WPD_E_USAGE, "expected 1 or 2 inputs, got %d", n);
    int w = opt->width, h = opt->height;
    if (w < WPD_PREVIEW_MIN_SIDE * n || h < WPD_PREVIEW_MIN_SIDE || w > WPD_PREVIEW_MAX_SIDE ||
        h > WPD_PREVIEW_MAX_SIDE || (uint64_t)w * (uint64_t)h > WPD_PREVIEW_MAX_PIXELS)
        return wpd_fail(err, WPD_E_USAGE,
                        "image size %d x %d: each side must be %d..%d (width >= %d for a "
                        "comparison) and width * height at most %u",
                        w, h, WPD_PREVIEW_MIN_SIDE, WPD_PREVIEW_MAX_SIDE,
                        2 * WPD_PREVIEW_MIN_SIDE, WPD_PREVIEW_MAX_PIXELS);
    return 0;
}

/* Rectangles: a single view fills the image; a comparison has two columns,
 * each a view above a histogram (a quarter of the height, at least 60 px). */
typedef struct layout {
    int view_w, view_h;
    int col_x[2];
    int hist_y, hist_h;
} layout;

static void make_layout(layout *l, int w, int h, int n)
{
    l->view_w = n == 2 ? (w - 2) / 2 : w;
    l->col_x[0] = 0;
    l->col_x[1] = w - l->view_w;
    l->hist_h = n == 2 ? (h / 4 > 60 ? h / 4 : 60) : 0;
    if (l->hist_h > h / 2)
        l->hist_h = h / 2;
    l->view_h = h - l->hist_h;
    l->hist_y = l->view_h;
}

/* One input's drawing pass and spacing, in the view v. */
static int draw_panel(panel *p, const view *v, const double origin[3], const double ext[3],
                      int by_rgb, wpd_batch *b, int threads, wpd_error *err)
{
    p->info.by_rgb = by_rgb;
    preview_sample_layout(&p->sample, ext, p->info.points);
    if (preview_panel_alloc(p, v, by_rgb, err) || preview_draw_pass(p, v, origin, b, err) ||
                        preview_measure_spacing(p, threads, err))
        return -1;
    p->info.spacing_count = p->nspacing;
    p->info.spacing_median = preview_quantile(p->spacing, p->nspacing, 0.5);
    p->info.spacing_p99 = preview_quantile(p->spacing, p->nspacing, 0.99);
    return 0;
}

/* Both passes over every input: pass 1 fixes the origin, the view and the
 * colouring (RGB only when every input has colours), pass 2 draws. */
static int read_inputs(panel *pn, int n, const layout *lay, int threads, view *v,
                       colouring *col, wpd_preview_summary *sum, wpd_error *err)
{
    wpd_batch b[2];
    memset(b, 0, sizeof b);
    int rc = 0;
    pn[0].track_views = 1;
    for (int i = 0; i < n && !rc; i++) {
        if (wpd_batch_init(&b[i], BATCH_POINTS,
                           wpd_cloud_header(pn[i].cloud, 0)->schema.record_size))
            rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a read batch", pn[i].path);
        else
            rc = preview_scan_pass(&pn[i], &b[i], err);
    }
    if (!rc) {
        col->by_rgb = !col->by_label;
        for (int i = 0; i < n; i++)
            col->by_rgb &= pn[i].rgb_denom > 0;
        for (int a = 0; a < 3; a++) {
            sum->origin[a] = pn[0].lo[a];
            sum->extent[a] = pn[0].hi[a] - pn[0].lo[a];
        }
        sum->azimuth = preview_choose_view(&pn[0], sum->origin, lay->view_w, lay->view_h, v);
        sum->scale = v->scale;
    }
    for (int i = 0; i < n && !rc; i++)
        rc = draw_panel(&pn[i], v, sum->origin, sum->extent, col->by_rgb, &b[i], threads, err);
    wpd_batch_free(&b[0]);
    wpd_batch_free(&b[1]);
    if (rc)
        return -1;
    if (col->by_rgb) {
        sum->z_lo = sum->z_hi = NAN;
        return 0;
    }
    if (preview_visible_height_range(&pn[0], v, &col->z_lo, &col->z_hi, err))
        return -1;
    sum->z_lo = col->z_lo;
    sum->z_hi = col->z_hi;
    return 0;
}

/* The picture: each panel's splats, then (comparison) the histograms on
 * one axis and a rule between the columns. */
static int paint(panel *pn, int n, const layout *lay, const view *v, const colouring *col,
                 wpd_preview_image *img, wpd_preview_summary *sum, wpd_error *err)
{
    size_t bytes = (size_t)img->width * img->height * 3;
    if (!(img->rgb = malloc(bytes)))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the picture", pn[0].path);
    for (size_t i = 0; i < bytes; i += 3)
        memcpy(img->rgb + i, background, 3);
    for (int i = 0; i < n; i++)
        if (preview_composite_panel(&pn[i], v, col, img, lay->col_x[i], 0, err))
            return -1;
    if (n < 2)
        return 0;
    double a = pn[0].info.spacing_p99, c = pn[1].info.spacing_p99;
    sum->hist_max = isnan(a) ? c : isnan(c) ? a : fmax(a, c);
    if (isnan(sum->hist_max))
        sum->hist_max = 0;
    for (int i = 0; i < n; i++)
        preview_draw_histogram(&pn[i], sum->hist_max, img, lay->col_x[i], lay->hist_y,
                               lay->view_w, lay->hist_h);
    static const uint8_t rule[3] = {200, 200, 196};
    preview_fill_rect(img, lay->view_w, 0, lay->col_x[1], img->height, rule);
    return 0;
}

static int render(panel *pn, int n, const wpd_preview_options *opt, wpd_preview_image *img,
                  wpd_preview_summary *sum, wpd_error *err)
{
    layout lay;
    make_layout(&lay, opt->width, opt->height, n);
    view v;
    memset(&v, 0, sizeof v);
    colouring col = {0, 0, 1, opt->label != NULL};
    if (read_inputs(pn, n, &lay, opt->threads, &v, &col, sum, err))
        return -1;
    img->width = opt->width;
    img->height = opt->height;
    return paint(pn, n, &lay, &v, &col, img, sum, err);
}

int wpd_preview_render(const char *const *paths, int n, const wpd_preview_options *opt,
                       wpd_preview_image *img, wpd_preview_summary *summary, wpd_error *err)
{
    memset(img, 0, sizeof *img);
    wpd_preview_summary local;
    wpd_preview_summary *sum = summary ? summary : &local;
    memset(sum, 0, sizeof *sum);
    if (check_size(opt, n, err))
        return -1;
    sum->panels = n;
    if (opt->label)
        snprintf(sum->label, sizeof sum->label, "%s", opt->label);
    sum->width = opt->width;
    sum->height = opt->height;
    panel pn[2];
    memset(pn, 0, sizeof pn);
    int rc = 0;
    for (int i = 0; i < n && !rc; i++) {
        pn[i].path = paths[i];
        pn[i].opt = opt;
        if (!(pn[i].cloud = wpd_cloud_open(&paths[i], 1, err)))
            rc = -1;
        else
            pn[i].info.warnings = wpd_cloud_header(pn[i].cloud, 0)->warnings;
    }
    if (!rc)
        rc = render(pn, n, opt, img, sum, err);
    for (int i = 0; i < n; i++) {
        sum->panel[i] = pn[i].info;
        preview_panel_free(&pn[i]);
    }
    if (rc)
        wpd_preview_image_free(img);
    return rc;
}

int wpd_preview_write(const char *const *paths, int n, const char *out,
                      const wpd_preview_options *opt, wpd_preview_summary *summary,
                      wpd_error *err)
{
    if (summary) /* zero where nothing gets read: the caller prints its warnings */
        memset(summary, 0, sizeof *summary);
    if (wpd_path_is_one_of(out, (char *const *)paths, n))
        return wpd_fail(err, WPD_E_USAGE, "%s: the output is also an input", out);
    wpd_outfile f;
    if (wpd_outfile_open(&f, out, opt->overwrite, err))
        return -1;
    wpd_preview_summary local;
    wpd_preview_summary *sum = summary ? summary : &local;
    wpd_preview_image img;
    uint8_t *png = NULL;
    size_t len = 0;
    char text[4096];
    int rc = wpd_preview_render(paths, n, opt, &img, sum, err);
    if (!rc) {
        wpd_preview_describe(sum, paths, text, sizeof text);
        const char *keys[2] = {"Software", "Description"};
        const char *texts[2] = {"wpd preview", text};
        rc = wpd_preview_encode_png(&img, keys, texts, 2, out, &png, &len, err);
    }
    wpd_preview_image_free(&img);
    if (!rc)
        rc = wpd_outfile_write(&f, png, len, err);
    free(png);
    if (!rc)
        return wpd_outfile_commit(&f, err);
    wpd_outfile_abort(&f);
    return -1;
}
