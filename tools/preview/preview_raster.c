/* preview_raster.c - `wpd preview`'s rasteriser: points into a 1-pixel
 * z-buffer, the z-buffer spread into squares of the smallest size that
 * leaves few holes, and the plane-free eye-dome shading that outlines
 * buildings and trees.
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <stdlib.h>

#define FILL_BLOCK 8              /* splat size: blocks judged for holes ... */
#define FILL_TARGET 0.9           /* ... and the share of them to cover */
#define EDL_STRENGTH 0.35         /* eye-dome shading per pixel of depth step */
#define EDL_TOLERANCE 1.0         /* depth steps ignored, in splat sides */
#define EDL_FLOOR 0.2             /* the darkest shade (edges stay coloured) */

/* Draws one point (relative coordinates q) at 1 pixel; the nearest wins,
 * the first of equals. */
void preview_draw_point(panel *p, const view *v, const double q[3], const uint8_t *rec,
                        const wpd_schema *s)
{
    double u, up, d;
    project(v, q, &u, &up, &d);
    double fx = floor(v->px0 + u * v->scale), fy = floor(v->py0 - up * v->scale);
    if (!(fx >= 0 && fx < v->w && fy >= 0 && fy < v->h))
        return;
    size_t i = (size_t)fy * (size_t)v->w + (size_t)fx;
    float depth = (float)(d * v->scale);
    if (!(depth < p->depth[i]))
        return;
    p->depth[i] = depth;
    p->z[i] = (float)q[2];
    if (p->label)
        p->label[i] = wpd_dim_get(&s->dims[p->label_dim], rec) != 0;
    if (p->rgb)
        for (int c = 0; c < 3; c++) {
            double t = wpd_dim_get(&s->dims[p->rgb_dim[c]], rec) / p->rgb_denom;
            p->rgb[3 * i + c] = (uint8_t)(t > 0 ? (t < 1 ? lround(t * 255) : 255) : 0);
        }
}

/* The 1-pixel z-buffer spread into squares of side `size`: from[q] is the
 * pixel whose point covers q (-1: background). Equivalent to drawing each
 * point as a square, as every point of a pixel shares its square. */
static void splat(const panel *p, const view *v, int size, float *depth, int32_t *from)
{
    size_t npix = (size_t)v->w * (size_t)v->h;
    for (size_t i = 0; i < npix; i++) {
        depth[i] = INFINITY;
        from[i] = -1;
    }
    int lo = -(size - 1) / 2, hi = size / 2;
    for (int y = 0; y < v->h; y++)
        for (int x = 0; x < v->w; x++) {
            size_t i = (size_t)y * v->w + x;
            float d = p->depth[i];
            if (!isfinite(d))
                continue;
            for (int dy = lo; dy <= hi; dy++)
                for (int dx = lo; dx <= hi; dx++) {
                    int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= v->w || yy >= v->h)
                        continue;
                    size_t j = (size_t)yy * v->w + xx;
                    if (d < depth[j]) {
                        depth[j] = d;
                        from[j] = (int32_t)i;
                    }
                }
        }
}

/* Eye-dome shading without the plane's own slope: for opposite neighbour
 * pairs at distance r, how far this pixel lies behind the midpoint of the
 * two (a plane gives 0, the ground beside a roof a large step). */
double preview_edl_shade(const float *depth, int w, int h, int x, int y, int r)
{
    static const int dirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
    float d = depth[(size_t)y * w + x];
    double excess = 0;
    for (int k = 0; k < 4; k++) {
        int ax = x + dirs[k][0] * r, ay = y + dirs[k][1] * r;
        int bx = x - dirs[k][0] * r, by = y - dirs[k][1] * r;
        if (ax < 0 || ay < 0 || bx < 0 || by < 0 || ax >= w || bx >= w || ay >= h || by >= h)
            continue;
        float da = depth[(size_t)ay * w + ax], db = depth[(size_t)by * w + bx];
        if (!isfinite(da) || !isfinite(db))
            continue;
        /* steps within EDL_TOLERANCE splat sides are surface noise */
        double e = d - 0.5 * ((double)da + db) - EDL_TOLERANCE * r;
        if (e > 0)
            excess += e / r;
    }
    return EDL_FLOOR + (1 - EDL_FLOOR) * exp(-EDL_STRENGTH * excess);
}

/* Of the pixels in FILL_BLOCK-square blocks that hold at least one drawn
 * point, the fraction that the splats cover (1 when nothing is drawn). */
static double fill_fraction(const panel *p, const view *v, const int32_t *from)
{
    uint64_t inside = 0, filled = 0;
    for (int by = 0; by < v->h; by += FILL_BLOCK)
        for (int bx = 0; bx < v->w; bx += FILL_BLOCK) {
            int ye = by + FILL_BLOCK < v->h ? by + FILL_BLOCK : v->h;
            int xe = bx + FILL_BLOCK < v->w ? bx + FILL_BLOCK : v->w;
            int any = 0;
            uint64_t f = 0;
            for (int y = by; y < ye; y++)
                for (int x = bx; x < xe; x++) {
                    size_t i = (size_t)y * v->w + x;
                    any |= isfinite(p->depth[i]);
                    f += from[i] >= 0;
                }
            if (any) {
                inside += (uint64_t)(ye - by) * (uint64_t)(xe - bx);
                filled += f;
            }
        }
    return inside ? (double)filled / (double)inside : 1;
}

int preview_composite_panel(panel *p, const view *v, const colouring *col,
                            wpd_preview_image *img, int x0, int y0, wpd_error *err)
{
    size_t npix = (size_t)v->w * (size_t)v->h;
    float *depth = malloc(npix * sizeof *depth);
    int32_t *from = malloc(npix * sizeof *from);
    if (!depth || !from) {
        free(depth);
        free(from);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory compositing the picture", p->path);
    }
    /* the smallest splat that leaves few holes where the cloud is */
    for (int size = 1; size <= 3; size++) {
        p->info.point_size = size;
        splat(p, v, size, depth, from);
        if (fill_fraction(p, v, from) >= FILL_TARGET)
            break;
    }
    preview_compose(p, v, col, depth, from, img, x0, y0);
    free(depth);
    free(from);
    return 0;
}
