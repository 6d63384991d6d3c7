/* preview_internal.h - what the parts of `wpd preview` share (see
 * preview.h for what the picture shows and the memory bound): the view,
 * the per-input panel with its z-buffer and spacing sample, the colouring,
 * and each part's functions. Only tools/preview*.c include it.
 *
 *   preview.c            the public API: size check, layout, both passes
 *                        over the inputs, painting the picture, the file
 *   preview_view.c       camera: candidate azimuths, fitting, choice
 *   preview_read.c       a panel's buffers and its two streaming passes
 *   preview_raster.c     z-buffer points, splats, eye-dome shading
 *   preview_colour.c     colour fields, viridis height ramp, pixel colours
 *   preview_spacing.c    windowed spacing sample, nearest-neighbour spacing
 *   preview_histogram.c  spacing histograms (comparison)
 *   preview_png.c        PNG encoding (palette or RGB, tEXt)
 *   preview_text.c       the description (stdout and tEXt)
 *   preview_cli.c        the `wpd preview` command line
 */
#ifndef WPD_TOOLS_PREVIEW_INTERNAL_H
#define WPD_TOOLS_PREVIEW_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/batch.h"
#include "io/cloud.h"
#include "tools/preview/preview.h"

#define MARGIN 12                 /* pixels around the fitted view */
#define AZIMUTHS 6                /* candidate azimuths: 0, 30, ..., 150 degrees */

/* ------------------------------------------------------------ the view */

typedef struct view {
    double ca, sa, ce, se;  /* cos/sin of azimuth and elevation */
    double scale;           /* pixels per coordinate unit */
    double px0, py0;        /* pixel of screen point (0, 0) within the view rectangle */
    int w, h;               /* view rectangle */
} view;

/* Screen coordinates of p: u to the right, v up, depth away from the
 * viewer (all in coordinate units). The cloud is turned by the azimuth,
 * then seen from the south, tilted down by the elevation. */
static inline void project(const view *v, const double p[3], double *u, double *up,
                           double *depth)
{
    double xr = p[0] * v->ca - p[1] * v->sa;
    double yr = p[0] * v->sa + p[1] * v->ca;
    *u = xr;
    *up = yr * v->se + p[2] * v->ce;
    *depth = yr * v->ce - p[2] * v->se;
}


/* ------------------------------------------------------------ a panel */

/* Points of the spacing sample: the whole cloud, or the points inside small
 * windows (see preview.h). */
typedef struct spacing_sample {
    int windowed;
    int axis[2];            /* window axes */
    double cell[2];         /* window grid pitch along them */
    double half[2];         /* window half sides (INFINITY: the whole axis) */
    double *xyz;            /* [3 * cap] */
    size_t n, cap;
} spacing_sample;

typedef struct panel {
    const char *path;
    wpd_cloud *cloud;
    int rgb_dim[3];          /* indices of red, green, blue, or -1 */
    int rgb_float;           /* the colour fields are floating point */
    double rgb_max;          /* largest colour value found */
    double rgb_denom;        /* divides a colour value into 0..1; 0: no colour */
    double lo[3], hi[3];     /* bounds of the finite points */
    int track_views;         /* measure the screen extents of each azimuth */
    double ext_lo[AZIMUTHS][2], ext_hi[AZIMUTHS][2]; /* u, v; absolute coordinates */
    wpd_preview_panel info;
    /* 1-pixel z-buffer over the view rectangle */
    float *depth;            /* pixels * depth from the viewer, INFINITY: empty */
    float *z;                /* height relative to the origin */
    uint8_t *rgb;            /* 3 per pixel, when coloured by RGB */
    spacing_sample sample;
    double *spacing;         /* sorted nearest-neighbour distances */
    size_t nspacing;
    const wpd_preview_options *opt; /* the label and the crop */
    int label_dim;           /* index of the label dimension, -1: none */
    uint8_t *label;          /* per pixel: 1 label set, when colouring by label */
} panel;

/* How pixels are coloured: by a label (red, else grey by height), by the
 * files' RGB, else by height on the viridis ramp over z_lo .. z_hi
 * (relative to the origin). */
typedef struct colouring {
    int by_rgb;
    double z_lo, z_hi;
    int by_label;
} colouring;

/* ------------------------------------------------------------ preview_view.c */

/* Extends p's screen extents of every candidate azimuth by the batch's
 * points (absolute coordinates). */
void preview_track_extents(panel *p, const wpd_batch *b);

/* Sets v to the candidate azimuth whose points (p's extents, tracked in
 * pass 1) fill a w x h rectangle best, fitted and centred, coordinates
 * relative to origin; returns its azimuth in degrees. */
double preview_choose_view(const panel *p, const double origin[3], int w, int h, view *v);

/* ------------------------------------------------------------ preview_read.c */

/* Closes p's file and frees its buffers; p is cleared. */
void preview_panel_free(panel *p);

/* Pass 1 over p's cloud (open, at its start), reading through b: bounds,
 * count, colour fields and depth, and (track_views) the candidate views'
 * extents; then rewinds. Returns 0, or -1 with err set (WPD_E_INPUT when no
 * point is finite). */
int preview_scan_pass(panel *p, wpd_batch *b, wpd_error *err);

/* Drops the points of b outside p's crop (none without one), keeping
 * the others in order. */
void preview_crop_batch(const panel *p, wpd_batch *b);

/* Allocates p's z-buffer for view v (RGB too when by_rgb, labels when
 * p->label_dim >= 0) and its spacing sample. Returns 0, or -1 with err set
 * (WPD_E_MEMORY). */
int preview_panel_alloc(panel *p, const view *v, int by_rgb, wpd_error *err);

/* Pass 2: every stride-th point (stride set here: at most 64
 * drawn per view pixel) into the z-buffer, every point offered to the
 * spacing sample; coordinates relative to origin. Returns 0 or -1. */
int preview_draw_pass(panel *p, const view *v, const double origin[3], wpd_batch *b,
                      wpd_error *err);

/* ------------------------------------------------------------ preview_raster.c */

/* Draws one point (relative coordinates q, record rec of schema s) at 1
 * pixel of p's z-buffer; the nearest wins, the first of equals. */
void preview_draw_point(panel *p, const view *v, const double q[3], const uint8_t *rec,
                        const wpd_schema *s);

/* Eye-dome shade (0.2 .. 1) of pixel (x, y) of a w x h depth image,
 * from its opposite neighbours at distance r. */
double preview_edl_shade(const float *depth, int w, int h, int x, int y, int r);

/* Spreads p's z-buffer into the smallest squares (1..3 px, set in
 * p->info.point_size) that leave few holes, and paints the shaded colours
 * into img at (x0, y0). Returns 0, or -1 with err set (WPD_E_MEMORY). */
int preview_composite_panel(panel *p, const view *v, const colouring *col,
                            wpd_preview_image *img, int x0, int y0, wpd_error *err);

/* ------------------------------------------------------------ preview_colour.c */

/* Finds p's colour fields (red/green/blue or diffuse_*): 1 and their
 * indices in p->rgb_dim, or 0 (indices -1). */
int preview_find_colour_dims(panel *p);

/* Largest value of colour dimension d in the batch (0 if none is larger). */
double preview_colour_max(const wpd_dim *d, const wpd_batch *b);

/* Sets p's colour depth (rgb_denom, info.rgb_bits) from the largest colour
 * value cmax; no colour (rgb_denom 0) when !has_rgb or cmax is 0. */
void preview_colour_depth(panel *p, int has_rgb, double cmax);

/* Paints the colours of the splatted pixels (from[q]: the z-buffer pixel
 * covering q, -1: none; depth: the splatted depths), shaded, into the
 * image rectangle at (x0, y0). */
void preview_compose(const panel *p, const view *v, const colouring *col, const float *depth,
                     const int32_t *from, wpd_preview_image *img, int x0, int y0);

/* Height ramp: 1st to 99th percentile of the heights visible in p (0 .. 1
 * when nothing is). Returns 0, or -1 with err set (WPD_E_MEMORY). */
int preview_visible_height_range(const panel *p, const view *v, double *lo, double *hi,
                                 wpd_error *err);

/* ------------------------------------------------------------ preview_spacing.c */

/* Chooses the sample's windows for a cloud of `points` points drawn in
 * the box [0, ext]: none when it is small enough to measure whole. */
void preview_sample_layout(spacing_sample *s, const double ext[3], uint64_t points);

/* Offers point p (relative coordinates) to the sample; the windows shrink
 * when it is full. */
void preview_sample_add(spacing_sample *s, const double p[3]);

/* Sorted nearest-neighbour distances of p's sample points whose neighbour
 * is certain (within the window) into p->spacing. Returns 0 or -1. */
int preview_measure_spacing(panel *p, int threads, wpd_error *err);

/* Value at fraction q (0..1) of sorted v[0..n-1] (nearest rank); NaN if n == 0. */
double preview_quantile(const double *v, size_t n, double q);

/* qsort comparison of doubles, ascending. */
int preview_cmp_double(const void *a, const void *b);

/* ------------------------------------------------------------ preview_histogram.c */

/* Fills [x0, x1) x [y0, y1) of img with colour c (clipped to the image). */
void preview_fill_rect(wpd_preview_image *img, int x0, int y0, int x1, int y1,
                       const uint8_t c[3]);

/* The spacing histogram of p over 0 .. hmax in the rectangle (x0, y0, w, h)
 * of img; counts the distances beyond hmax in p->info.hist_beyond. */
void preview_draw_histogram(panel *p, double hmax, wpd_preview_image *img, int x0, int y0,
                            int w, int h);

#endif
