/* preview_histogram.c - the spacing histograms of a `wpd preview`
 * comparison: bars on a common axis, ticks at quarters, the median as an
 * orange line; drawn without text (the numbers go to the description).
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <string.h>

static const uint8_t bar_colour[3] = {58, 84, 140};
static const uint8_t axis_colour[3] = {60, 60, 60};
static const uint8_t median_colour[3] = {230, 120, 20};

static void put_pixel(wpd_preview_image *img, int x, int y, const uint8_t c[3])
{
    if (x < 0 || y < 0 || x >= img->width || y >= img->height)
        return;
    memcpy(img->rgb + 3 * ((size_t)y * img->width + x), c, 3);
}

void preview_fill_rect(wpd_preview_image *img, int x0, int y0, int x1, int y1, const uint8_t c[3])
{
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            put_pixel(img, x, y, c);
}

/* The spacing histogram of p over 0 .. hmax in the rectangle (x0, y0, w, h):
 * bars up from a baseline, ticks below it, the median as an orange line. */
void preview_draw_histogram(panel *p, double hmax, wpd_preview_image *img, int x0, int y0,
                            int w, int h)
{
    int left = x0 + 2 * MARGIN, right = x0 + w - 2 * MARGIN;
    int base = y0 + h - MARGIN - 8, top = y0 + MARGIN;
    if (right - left < WPD_PREVIEW_HIST_BINS || base - top < 8)
        return;
    uint64_t bins[WPD_PREVIEW_HIST_BINS] = {0}, peak = 0;
    for (size_t i = 0; i < p->nspacing; i++) {
        double t = hmax > 0 ? p->spacing[i] / hmax : 0;
        if (t > 1) {
            p->info.hist_beyond++;
            continue;
        }
        int b = (int)(t * WPD_PREVIEW_HIST_BINS);
        bins[b < WPD_PREVIEW_HIST_BINS ? b : WPD_PREVIEW_HIST_BINS - 1]++;
    }
    for (int b = 0; b < WPD_PREVIEW_HIST_BINS; b++)
        if (bins[b] > peak)
            peak = bins[b];
    double bw = (double)(right - left) / WPD_PREVIEW_HIST_BINS;
    for (int b = 0; peak && b < WPD_PREVIEW_HIST_BINS; b++) {
        int bx0 = left + (int)lround(b * bw), bx1 = left + (int)lround((b + 1) * bw) - 1;
        int bh = (int)lround((double)bins[b] / (double)peak * (base - top));
        if (bx1 <= bx0)
            bx1 = bx0 + 1;
        preview_fill_rect(img, bx0, base - bh, bx1, base, bar_colour);
    }
    preview_fill_rect(img, left, base, right + 1, base + 1, axis_colour);
    for (int t = 0; t <= 4; t++) {
        int x = left + (int)lround(t * (right - left) / 4.0);
        preview_fill_rect(img, x, base + 1, x + 1, base + (t % 2 ? 5 : 8), axis_colour);
    }
    double med = p->info.spacing_median;
    if (med >= 0 && med <= hmax && hmax > 0) {
        int x = left + (int)lround(med / hmax * (right - left));
        preview_fill_rect(img, x, top, x + 1, base, median_colour);
    }
}
