/* preview_colour.c - `wpd preview`'s colours: the file's colour fields
 * and their bit depth, the viridis height ramp over the visible heights,
 * and the shaded colour of each pixel (quantised when by height, so the
 * picture fits a palette PNG).
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Height colours are quantised (ramp levels x shade levels) so that the
 * picture has at most 256 colours and is stored as a small palette PNG. */
#define RAMP_LEVELS 30
#define SHADE_LEVELS 8

/* viridis (matplotlib) at 0, 0.1, ..., 1. */
static const uint8_t viridis_stops[11][3] = {
    {68, 1, 84},    {72, 36, 117},  {65, 68, 135},  {53, 95, 141},
    {42, 120, 142}, {33, 145, 140}, {34, 168, 132}, {68, 191, 112},
    {122, 209, 81}, {189, 223, 38}, {253, 231, 37}};

static void viridis(double t, uint8_t out[3])
{
    if (!(t > 0))
        t = 0;
    if (t > 1)
        t = 1;
    double f = t * 10;
    int i = (int)f;
    if (i > 9)
        i = 9;
    f -= i;
    for (int c = 0; c < 3; c++)
        out[c] = (uint8_t)lround(viridis_stops[i][c] * (1 - f) + viridis_stops[i + 1][c] * f);
}

int preview_find_colour_dims(panel *p)
{
    static const char *names[2][3] = {{"red", "green", "blue"},
                                      {"diffuse_red", "diffuse_green", "diffuse_blue"}};
    const wpd_schema *s = &wpd_cloud_header(p->cloud, 0)->schema;
    for (int set = 0; set < 2; set++) {
        int found = 1;
        for (int c = 0; c < 3; c++)
            found &= (p->rgb_dim[c] = wpd_schema_find(s, names[set][c])) >= 0;
        if (found) {
            wpd_type t = s->dims[p->rgb_dim[0]].type;
            p->rgb_float = t == WPD_F32 || t == WPD_F64;
            return 1;
        }
    }
    p->rgb_dim[0] = p->rgb_dim[1] = p->rgb_dim[2] = -1;
    return 0;
}

/* Largest value of colour dimension d in the batch (0 if none is larger;
 * NaN never compares greater). */
double preview_colour_max(const wpd_dim *d, const wpd_batch *b)
{
    double m = 0;
    const uint8_t *rec = b->records;
    if (d->bit_count == 0 && !d->scaled && d->type == WPD_U16) {
        uint16_t mu = 0; /* LAS colours: the common case, kept tight */
        for (size_t i = 0; i < b->n; i++, rec += b->record_size) {
            uint16_t v;
            memcpy(&v, rec + d->offset, 2);
            mu = v > mu ? v : mu;
        }
        return mu;
    }
    for (size_t i = 0; i < b->n; i++, rec += b->record_size) {
        double v = wpd_dim_get(d, rec);
        m = v > m ? v : m;
    }
    return m;
}

void preview_colour_depth(panel *p, int has_rgb, double cmax)
{
    p->rgb_max = cmax;
    if (has_rgb && cmax > 0) {
        if (p->rgb_float && cmax <= 1.0)
            p->rgb_denom = 1.0, p->info.rgb_bits = 0;
        else if (cmax <= 255)
            p->rgb_denom = 255, p->info.rgb_bits = 8;
        else if (cmax <= 65535)
            p->rgb_denom = 65535, p->info.rgb_bits = 16;
        else
            p->rgb_denom = cmax, p->info.rgb_bits = 0;
    }
}

/* Shaded colours of panel p into the image rectangle at (x0, y0). */
void preview_compose(const panel *p, const view *v, const colouring *col, const float *depth,
                     const int32_t *from, wpd_preview_image *img, int x0, int y0)
{
    int r = p->info.point_size;
    double zspan = col->z_hi - col->z_lo;
    for (int y = 0; y < v->h; y++)
        for (int x = 0; x < v->w; x++) {
            int32_t src = from[(size_t)y * v->w + x];
            if (src < 0)
                continue;
            uint8_t c[3];
            double shade = preview_edl_shade(depth, v->w, v->h, x, y, r);
            if (col->by_label && p->label[src]) {
                static const uint8_t red[3] = {230, 25, 25};
                memcpy(c, red, 3);
                shade = round(shade * (SHADE_LEVELS - 1)) / (SHADE_LEVELS - 1);
            } else if (col->by_rgb) {
                memcpy(c, p->rgb + 3 * (size_t)src, 3);
            } else {
                double t = zspan > 0 ? (p->z[src] - col->z_lo) / zspan : 0.5;
                t = t > 0 ? (t < 1 ? t : 1) : 0;
                t = round(t * (RAMP_LEVELS - 1)) / (RAMP_LEVELS - 1);
                if (col->by_label) /* grey, darker below: the red stands out */
                    c[0] = c[1] = c[2] = (uint8_t)lround(110 + 110 * t);
                else
                    viridis(t, c);
                shade = round(shade * (SHADE_LEVELS - 1)) / (SHADE_LEVELS - 1);
            }
            uint8_t *o = img->rgb + 3 * ((size_t)(y0 + y) * img->width + (size_t)(x0 + x));
            for (int k = 0; k < 3; k++)
                o[k] = (uint8_t)lround(c[k] * shade);
        }
}

/* Height ramp: 1st to 99th percentile of the heights visible in p. */
int preview_visible_height_range(const panel *p, const view *v, double *lo, double *hi,
                                 wpd_error *err)
{
    size_t npix = (size_t)v->w * (size_t)v->h, n = 0;
    double *zs = malloc(npix * sizeof *zs);
    if (!zs)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the height ramp", p->path);
    for (size_t i = 0; i < npix; i++)
        if (isfinite(p->depth[i]))
            zs[n++] = p->z[i];
    qsort(zs, n, sizeof *zs, preview_cmp_double);
    *lo = n ? preview_quantile(zs, n, 0.01) : 0;
    *hi = n ? preview_quantile(zs, n, 0.99) : 1;
    free(zs);
    return 0;
}
