/* preview.h - `wpd preview`: PNG pictures of point clouds (libpng).
 *
 *   wpd preview FILE -o out.png            one oblique view of the cloud
 *   wpd preview BEFORE AFTER -o cmp.png    the two side by side, same view
 *                                          and scale (BEFORE's bounds), each
 *                                          above a histogram of its
 *                                          nearest-neighbour spacing
 *
 * View: orthographic, the cloud turned by the azimuth about the vertical and
 * seen from 35 degrees above the horizon, fitted to the image (the extent
 * of the points themselves, not of their bounding box). The azimuth is 30
 * degrees unless another multiple of 30 lets the points fill the picture
 * at a scale at least 10 % larger (a long strip seen end-on would waste
 * it). Coordinates are taken relative to the bounds' minimum corner
 * (georeferenced values lose nothing). Points go into a z-buffer, then are
 * spread into squares of the smallest side (1-3 px) that covers 90 % of
 * the pixels of the 8 x 8 px blocks the cloud touches, so dense clouds
 * stay sharp and sparse ones show few holes. A plane-free eye-dome shading
 * darkens pixels that lie behind the midpoint of their neighbours (a
 * plane, however tilted, is not shaded), which outlines buildings and trees.
 * Label (--label DIM): points whose DIM is not zero are drawn red, the
 * others grey by height (the viridis ramp's positions, in grey), e.g. the
 * edge label of `wpd resample --edge-label`; a file without DIM is an
 * error. Crop (--crop X0,Y0,X1,Y1): only the points with X0 <= x < X1 and
 * Y0 <= y < Y1 (absolute coordinates) are read into the picture, its
 * bounds and its spacing: a closer look at part of a large scan.
 * Colour: the file's red/green/blue when it has them and they are not all
 * zero (the bit depth is detected from the largest value found: <= 1.0 in a
 * float field: 0..1; <= 255: 8-bit; else 16-bit), otherwise height on the
 * viridis ramp between the 1st and 99th percentile of the visible heights.
 * In a comparison, RGB is used only when both files have it, and both
 * panels share BEFORE's height ramp.
 *
 * Streaming and memory: each file is read twice through io/cloud.h (pass 1:
 * bounds, point count, colour range; pass 2: drawing). Nothing per point is
 * kept, except the spacing sample below: the z-buffer is drawn while
 * streaming, so memory does not depend on the input's size. More than 64
 * points per view pixel are never needed: beyond that a deterministic stride
 * (every k-th finite point) is drawn, which bounds the drawing time.
 * Memory bound: about 20 bytes per image pixel + 20 MB (spacing sample and
 * its grid, one read batch) whatever the input: measured 25 MB at
 * 1200 x 700 and 87 MB at the largest image (WPD_PREVIEW_MAX_PIXELS) on a
 * 20 M point LAS file.
 * Output: height-coloured pictures are quantised (30 ramp x 8 shade levels)
 * and stored as palette PNGs (about 130 KB at 1200 x 700); RGB pictures
 * are stored as 8-bit RGB.
 *
 * Spacing: nearest-neighbour distance (k = 1, core/knn.h) measured in the
 * full cloud, not in a thinned one (thinning would stretch the spacing).
 * A cloud of at most WPD_PREVIEW_SAMPLE_MAX points is measured whole;
 * a larger one on the points inside 8 x 8 small square windows laid out
 * regularly over BEFORE's bounds (on the two widest axes), sized to hold
 * about half of WPD_PREVIEW_SAMPLE_MAX points; should they fill up, every
 * window shrinks about its centre (all the points inside stay known). Only
 * points whose neighbour is nearer than the window's border are counted, so
 * each distance is exact. Deterministic: the same input gives the same
 * bytes whatever the thread count.
 *
 * Histograms (comparison only): 60 bins on one axis 0 .. hmax for both,
 * hmax = the larger of the two clouds' 99th percentiles of spacing; bars
 * scaled to each histogram's own peak; distances beyond hmax are left out.
 * Ticks (plain lines, no text) at 0, 1/4, 1/2, 3/4 and 1 of the axis; a
 * thin orange line marks the median. The numbers (point counts, axis range,
 * medians, colour range) go to a PNG tEXt chunk (key "Description") and to
 * standard output. No font is needed.
 */
#ifndef WPD_TOOLS_PREVIEW_H
#define WPD_TOOLS_PREVIEW_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "common/warnings.h"
#include "io/schema.h"

#define WPD_PREVIEW_DEFAULT_WIDTH 1200
#define WPD_PREVIEW_DEFAULT_HEIGHT 700
#define WPD_PREVIEW_MIN_SIDE 64
#define WPD_PREVIEW_MAX_SIDE 4096
#define WPD_PREVIEW_MAX_PIXELS (4096u * 1024u)   /* width * height */
#define WPD_PREVIEW_AZIMUTH_DEG 30.0     /* preferred; see above */
#define WPD_PREVIEW_ELEVATION_DEG 35.0
#define WPD_PREVIEW_SAMPLE_MAX 200000            /* spacing sample, points */
#define WPD_PREVIEW_HIST_BINS 60

typedef struct wpd_preview_options {
    int width, height;  /* image size in pixels (defaults 1200 x 700) */
    int overwrite;      /* 1: replace an existing output */
    int threads;        /* kNN threads, <= 0: OpenMP default */
    const char *label;  /* a dimension to colour by: non-zero red, zero grey by
                           height (NULL: RGB or height as above) */
    int crop;           /* 1: draw only the points with crop_lo <= x, y < crop_hi */
    double crop_lo[2], crop_hi[2];
} wpd_preview_options;

/* What was drawn for one input. */
typedef struct wpd_preview_panel {
    uint64_t points;         /* finite points in the file */
    uint64_t stride;         /* every stride-th point was drawn */
    uint64_t drawn;          /* points drawn (some may fall outside the view) */
    int point_size;          /* splat side in pixels, 1..3 */
    int by_rgb;              /* 1: coloured by red/green/blue, 0: by height */
    int rgb_bits;            /* 8 or 16 (0: float 0..1 or no colour) */
    uint64_t spacing_count;  /* nearest-neighbour distances measured */
    double spacing_median;   /* NaN when none */
    double spacing_p99;      /* 99th percentile, NaN when none */
    uint64_t hist_beyond;    /* distances beyond the histogram axis */
    uint64_t labelled;       /* points drawn with a non-zero label (--label) */
    wpd_warnings warnings;   /* the file's (common/warnings.h), once it opened */
} wpd_preview_panel;

typedef struct wpd_preview_summary {
    int panels;                  /* 1 or 2 */
    int width, height;
    wpd_preview_panel panel[2];
    double origin[3];            /* minimum corner of the drawn bounds */
    double extent[3];            /* size of the drawn bounds */
    double azimuth;              /* degrees, of the view chosen */
    double scale;                /* pixels per coordinate unit */
    double z_lo, z_hi;           /* height ramp, relative to origin[2] */
    double hist_max;             /* histogram axis 0 .. hist_max (2 panels) */
    char label[WPD_DIM_NAME_MAX];/* the dimension coloured by, "" for none */
} wpd_preview_summary;

/* An RGB image, 3 bytes per pixel, rows top to bottom. */
typedef struct wpd_preview_image {
    int width, height;
    uint8_t *rgb;
} wpd_preview_image;

/* Sets the defaults: 1200 x 700, no overwrite, default threads. */
void wpd_preview_defaults(wpd_preview_options *opt);

/* Renders paths[0] (n == 1) or paths[0] beside paths[1] (n == 2) into a new
 * image (free with wpd_preview_image_free) and fills summary (may be NULL).
 * Returns 0, or -1 with err set naming the file: WPD_E_USAGE for a bad size
 * or n, WPD_E_INPUT for a file without finite points or unreadable, WPD_E_IO,
 * WPD_E_MEMORY. */
int wpd_preview_render(const char *const *paths, int n, const wpd_preview_options *opt,
                       wpd_preview_image *img, wpd_preview_summary *summary, wpd_error *err);

/* Encodes img as an 8-bit RGB PNG with the given tEXt chunks (keys[i],
 * texts[i], i < ntext; Latin-1) into a new buffer *png of *len bytes (free()
 * it). No time chunk: equal inputs give equal bytes. Returns 0 or -1
 * (WPD_E_MEMORY, or WPD_E_IO naming `name` when libpng fails). */
int wpd_preview_encode_png(const wpd_preview_image *img, const char *const *keys,
                           const char *const *texts, int ntext, const char *name,
                           uint8_t **png, size_t *len, wpd_error *err);

/* The summary as text: one line per input (counts, stride, colouring, point
 * size, spacing) and, for a comparison, the histogram axis. paths as given
 * to wpd_preview_render. Always NUL-terminates buf (len > 0). */
void wpd_preview_describe(const wpd_preview_summary *s, const char *const *paths, char *buf,
                          size_t len);

/* Renders and writes the PNG to out through a temporary file renamed on
 * success (common/outfile.h; no file is left behind on failure). The
 * description goes into the tEXt chunk. Returns 0 or -1 with err set
 * (WPD_E_USAGE: out exists without overwrite, or out is one of the inputs). */
int wpd_preview_write(const char *const *paths, int n, const char *out,
                      const wpd_preview_options *opt, wpd_preview_summary *summary,
                      wpd_error *err);

void wpd_preview_image_free(wpd_preview_image *img);

/* The subcommand: argv[0] = "preview". Returns the exit status. */
int wpd_preview_main(int argc, char **argv);

#endif
