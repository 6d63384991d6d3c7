/* preview.c - PNG pictures of point clouds; see preview.h for the view,
 * colours, spacing histograms and the memory bound. */
#include "preview.h"

#include "common/outfile.h"
#include "core/grid.h"
#include "core/knn.h"
#include "io/cloud.h"

#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define BATCH_POINTS 65536
#define MARGIN 12                 /* pixels around the fitted view */
#define WINDOWS_PER_AXIS 8        /* spacing sample windows: 8 x 8 */
#define DRAW_PER_PIXEL 64         /* points per view pixel worth drawing */
#define FILL_BLOCK 8              /* splat size: blocks judged for holes ... */
#define FILL_TARGET 0.9           /* ... and the share of them to cover */
#define EDL_STRENGTH 0.35         /* eye-dome shading per pixel of depth step */
#define EDL_TOLERANCE 1.0         /* depth steps ignored, in splat sides */
#define EDL_FLOOR 0.2             /* the darkest shade (edges stay coloured) */
/* Height colours are quantised (ramp levels x shade levels) so that the
 * picture has at most 256 colours and is stored as a small palette PNG. */
#define RAMP_LEVELS 30
#define SHADE_LEVELS 8

static const uint8_t background[3] = {246, 246, 242};
static const uint8_t bar_colour[3] = {58, 84, 140};
static const uint8_t axis_colour[3] = {60, 60, 60};
static const uint8_t median_colour[3] = {230, 120, 20};

/* ---- colours ---- */

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

/* ---- the view ---- */

typedef struct view {
    double ca, sa, ce, se;  /* cos/sin of azimuth and elevation */
    double scale;           /* pixels per coordinate unit */
    double px0, py0;        /* pixel of screen point (0, 0) within the view rectangle */
    int w, h;               /* view rectangle */
} view;

/* Screen coordinates of p: u to the right, v up, depth away from the
 * viewer (all in coordinate units). The cloud is turned by the azimuth,
 * then seen from the south, tilted down by the elevation. */
static void project(const view *v, const double p[3], double *u, double *up, double *depth)
{
    double xr = p[0] * v->ca - p[1] * v->sa;
    double yr = p[0] * v->sa + p[1] * v->ca;
    *u = xr;
    *up = yr * v->se + p[2] * v->ce;
    *depth = yr * v->ce - p[2] * v->se;
}

/* Candidate azimuths: 0, 30, ..., 150 degrees (a and a + 180 fit alike). */
#define AZIMUTHS 6
#define AZIMUTH_STEP 30.0
#define PREFERRED_AZIMUTH 1     /* WPD_PREVIEW_AZIMUTH_DEG */

static void view_angles(view *v, double azimuth_deg)
{
    const double deg = M_PI / 180;
    v->ca = cos(azimuth_deg * deg);
    v->sa = sin(azimuth_deg * deg);
    v->ce = cos(WPD_PREVIEW_ELEVATION_DEG * deg);
    v->se = sin(WPD_PREVIEW_ELEVATION_DEG * deg);
}

/* Pixels per unit that fit screen extents du x dv into a w x h rectangle. */
static double fit_scale(double du, double dv, int w, int h)
{
    double room_w = w > 2 * MARGIN + 1 ? w - 2 * MARGIN : 1;
    double room_h = h > 2 * MARGIN + 1 ? h - 2 * MARGIN : 1;
    double s = INFINITY;
    if (du > 0)
        s = room_w / du;
    if (dv > 0)
        s = fmin(s, room_h / dv);
    return isfinite(s) ? s : 1; /* a single point */
}

/* The view at azimuth_deg whose screen extents (relative coordinates) are
 * [ulo, uhi] x [vlo, vhi], centred in a w x h rectangle. */
static void view_fit(view *v, double azimuth_deg, double ulo, double uhi, double vlo, double vhi,
                     int w, int h)
{
    view_angles(v, azimuth_deg);
    v->w = w;
    v->h = h;
    double s = fit_scale(uhi - ulo, vhi - vlo, w, h);
    v->scale = s;
    v->px0 = w / 2.0 - (ulo + uhi) / 2 * s;
    v->py0 = h / 2.0 + (vlo + vhi) / 2 * s;
}

/* ---- one panel: a file, its 1-pixel z-buffer and spacing sample ---- */

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
} panel;

static void panel_free(panel *p)
{
    wpd_cloud_close(p->cloud);
    free(p->depth);
    free(p->z);
    free(p->rgb);
    free(p->sample.xyz);
    free(p->spacing);
    memset(p, 0, sizeof *p);
}

static int find_colour_dims(panel *p)
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

/* Extends the screen extents of every candidate azimuth by the batch's
 * points (absolute coordinates: the projection is linear, the origin is
 * subtracted afterwards). */
static void track_extents(panel *p, const wpd_batch *b)
{
    view v;
    for (int a = 0; a < AZIMUTHS; a++) {
        view_angles(&v, a * AZIMUTH_STEP);
        double ulo = p->ext_lo[a][0], uhi = p->ext_hi[a][0];
        double vlo = p->ext_lo[a][1], vhi = p->ext_hi[a][1];
        const double *q = b->xyz;
        const double cx = v.ca, sx = v.sa, ce = v.ce, se = v.se;
        /* vectorised: this loop is most of pass 1's work */
#pragma omp simd reduction(min : ulo, vlo) reduction(max : uhi, vhi)
        for (size_t i = 0; i < b->n; i++) {
            double x = q[3 * i], y = q[3 * i + 1], z = q[3 * i + 2];
            double u = x * cx - y * sx;
            double up = (x * sx + y * cx) * se + z * ce;
            ulo = u < ulo ? u : ulo;
            uhi = u > uhi ? u : uhi;
            vlo = up < vlo ? up : vlo;
            vhi = up > vhi ? up : vhi;
        }
        p->ext_lo[a][0] = ulo, p->ext_hi[a][0] = uhi;
        p->ext_lo[a][1] = vlo, p->ext_hi[a][1] = vhi;
    }
}

/* Largest value of colour dimension d in the batch (0 if none is larger;
 * NaN never compares greater). */
static double colour_max(const wpd_dim *d, const wpd_batch *b)
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

/* Pass 1: bounds, count, the largest colour value and (track_views) the
 * screen extents of the candidate views. */
static int scan_pass(panel *p, wpd_batch *b, wpd_error *err)
{
    const wpd_schema *s = &wpd_cloud_header(p->cloud, 0)->schema;
    int has_rgb = find_colour_dims(p);
    wpd_bounds bb;
    wpd_bounds_reset(&bb);
    double cmax = 0;
    for (int a = 0; a < AZIMUTHS; a++)
        for (int k = 0; k < 2; k++)
            p->ext_lo[a][k] = INFINITY, p->ext_hi[a][k] = -INFINITY;
    long got;
    while ((got = wpd_cloud_read(p->cloud, b, NULL, err)) > 0) {
        wpd_bounds_add(&bb, b->xyz, b->n);
        if (p->track_views)
            track_extents(p, b);
        for (int c = 0; has_rgb && c < 3; c++)
            cmax = fmax(cmax, colour_max(&s->dims[p->rgb_dim[c]], b));
    }
    if (got < 0)
        return -1;
    if (bb.count == 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates", p->path);
    memcpy(p->lo, bb.min, sizeof p->lo);
    memcpy(p->hi, bb.max, sizeof p->hi);
    p->info.points = bb.count;
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
    return wpd_cloud_rewind(p->cloud, err);
}

/* ---- spacing sample ---- */

/* Chooses the windows for a cloud of `points` points drawn in the box
 * [0, ext]: none when it is small enough to measure whole. */
static void sample_layout(spacing_sample *s, const double ext[3], uint64_t points)
{
    s->windowed = points > WPD_PREVIEW_SAMPLE_MAX;
    if (!s->windowed)
        return;
    /* the two widest axes */
    int a0 = 0, a1 = 1, a2 = 2;
    if (ext[a1] > ext[a0]) { int t = a0; a0 = a1; a1 = t; }
    if (ext[a2] > ext[a0]) { int t = a0; a0 = a2; a2 = t; }
    if (ext[a2] > ext[a1]) { int t = a1; a1 = a2; a2 = t; }
    s->axis[0] = a0;
    s->axis[1] = a1;
    /* each window holds sqrt(f) of its cell per axis, f of the points */
    double f = (WPD_PREVIEW_SAMPLE_MAX / 2.0) / (double)points;
    for (int k = 0; k < 2; k++) {
        double e = ext[s->axis[k]];
        s->cell[k] = e > 0 ? e / WINDOWS_PER_AXIS : 1;
        s->half[k] = e > 0 ? s->cell[k] * sqrt(f) / 2 : INFINITY;
    }
}

/* Distance from p to the border of its window, or -1 when p is outside
 * every window. */
static double window_border(const spacing_sample *s, const double p[3])
{
    double border = INFINITY;
    for (int k = 0; k < 2; k++) {
        if (isinf(s->half[k]))
            continue;
        double c = s->cell[k], x = p[s->axis[k]];
        double i = floor(x / c);
        if (i < 0)
            i = 0;
        if (i > WINDOWS_PER_AXIS - 1)
            i = WINDOWS_PER_AXIS - 1;
        double off = fabs(x - (i + 0.5) * c);
        if (off > s->half[k])
            return -1;
        border = fmin(border, s->half[k] - off);
    }
    return border;
}

/* The windows are full: halve their sides about their centres and keep
 * the points still inside (all points of the smaller windows are known,
 * since they lie in the larger ones). */
static void sample_shrink(spacing_sample *s)
{
    for (int k = 0; k < 2; k++)
        s->half[k] /= 2;
    size_t kept = 0;
    for (size_t i = 0; i < s->n; i++)
        if (window_border(s, s->xyz + 3 * i) >= 0) {
            memmove(s->xyz + 3 * kept, s->xyz + 3 * i, 3 * sizeof *s->xyz);
            kept++;
        }
    s->n = kept;
}

static void sample_add(spacing_sample *s, const double p[3])
{
    if (s->windowed) {
        if (window_border(s, p) < 0)
            return;
        while (s->n == s->cap) {
            sample_shrink(s);
            if (window_border(s, p) < 0)
                return;
        }
    }
    memcpy(s->xyz + 3 * s->n, p, 3 * sizeof *p);
    s->n++;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Nearest-neighbour distance of every sample point whose neighbour is
 * certain (within its window), sorted. */
static int measure_spacing(panel *p, int threads, wpd_error *err)
{
    spacing_sample *s = &p->sample;
    p->nspacing = 0;
    if (s->n < 2)
        return 0;
    uint32_t *self = malloc(s->n * sizeof *self);
    uint32_t *idx = malloc(s->n * sizeof *idx);
    double *d2 = malloc(s->n * sizeof *d2);
    uint8_t *count = malloc(s->n);
    p->spacing = malloc(s->n * sizeof *p->spacing);
    wpd_grid g;
    memset(&g, 0, sizeof g);
    int rc = 0;
    if (!self || !idx || !d2 || !count || !p->spacing) {
        rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory measuring the spacing", p->path);
        goto done;
    }
    double lo[3], hi[3];
    wpd_point_bounds(s->xyz, NULL, s->n, lo, hi, threads);
    double area = 1;
    if (s->windowed) {
        for (int k = 0; k < 2; k++)
            area *= isinf(s->half[k]) ? hi[s->axis[k]] - lo[s->axis[k]] : 2 * s->half[k];
        area *= WINDOWS_PER_AXIS * WINDOWS_PER_AXIS;
    } else {
        double e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
        qsort(e, 3, sizeof *e, cmp_double);
        area = e[2] * (e[1] > 0 ? e[1] : e[2]);
    }
    double guess = sqrt(area / (double)s->n);
    if (!(guess > 0) || !isfinite(guess))
        guess = 1;
    if (wpd_grid_build_knn(&g, s->xyz, NULL, s->n, 1, guess, threads, err)) {
        rc = -1;
        goto done;
    }
    for (size_t i = 0; i < s->n; i++)
        self[i] = (uint32_t)i;
    wpd_knn_many(&g, s->xyz, self, s->n, 1, INFINITY, idx, d2, count, threads);
    for (size_t i = 0; i < s->n; i++) {
        if (!count[i])
            continue;
        double d = sqrt(d2[i]);
        if (s->windowed && window_border(s, s->xyz + 3 * i) < d)
            continue; /* a nearer neighbour may lie outside the window */
        p->spacing[p->nspacing++] = d;
    }
    qsort(p->spacing, p->nspacing, sizeof *p->spacing, cmp_double);
done:
    wpd_grid_free(&g);
    free(self);
    free(idx);
    free(d2);
    free(count);
    return rc;
}

/* Value at fraction q (0..1) of sorted v[0..n-1] (nearest rank); NaN if n == 0. */
static double quantile(const double *v, size_t n, double q)
{
    if (n == 0)
        return NAN;
    size_t i = (size_t)(q * (double)(n - 1) + 0.5);
    return v[i < n ? i : n - 1];
}

/* ---- pass 2: drawing ---- */

static int panel_alloc(panel *p, const view *v, int by_rgb, wpd_error *err)
{
    size_t npix = (size_t)v->w * (size_t)v->h;
    p->depth = malloc(npix * sizeof *p->depth);
    p->z = malloc(npix * sizeof *p->z);
    if (by_rgb)
        p->rgb = malloc(npix * 3);
    p->sample.cap = WPD_PREVIEW_SAMPLE_MAX;
    p->sample.xyz = malloc(p->sample.cap * 3 * sizeof *p->sample.xyz);
    if (!p->depth || !p->z || (by_rgb && !p->rgb) || !p->sample.xyz)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a %d x %d picture", p->path,
                        v->w, v->h);
    for (size_t i = 0; i < npix; i++)
        p->depth[i] = INFINITY;
    return 0;
}

/* Draws one point (relative coordinates q) at 1 pixel; the nearest wins,
 * the first of equals. */
static void draw_point(panel *p, const view *v, const double q[3], const uint8_t *rec,
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
    if (p->rgb)
        for (int c = 0; c < 3; c++) {
            double t = wpd_dim_get(&s->dims[p->rgb_dim[c]], rec) / p->rgb_denom;
            p->rgb[3 * i + c] = (uint8_t)(t > 0 ? (t < 1 ? lround(t * 255) : 255) : 0);
        }
}

/* Pass 2: every stride-th point into the z-buffer, every point offered to
 * the spacing sample. */
static int draw_pass(panel *p, const view *v, const double origin[3], wpd_batch *b,
                     wpd_error *err)
{
    const wpd_schema *s = &wpd_cloud_header(p->cloud, 0)->schema;
    uint64_t limit = (uint64_t)DRAW_PER_PIXEL * (uint64_t)v->w * (uint64_t)v->h;
    p->info.stride = p->info.points > limit ? (p->info.points + limit - 1) / limit : 1;
    uint64_t ordinal = 0;
    long got;
    while ((got = wpd_cloud_read(p->cloud, b, NULL, err)) > 0) {
        for (size_t i = 0; i < b->n; i++, ordinal++) {
            const double *a = b->xyz + 3 * i;
            double q[3] = {a[0] - origin[0], a[1] - origin[1], a[2] - origin[2]};
            sample_add(&p->sample, q);
            if (ordinal % p->info.stride == 0) {
                draw_point(p, v, q, b->records + i * b->record_size, s);
                p->info.drawn++;
            }
        }
    }
    return got < 0 ? -1 : 0;
}

/* ---- compositing ---- */

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
static double edl_shade(const float *depth, int w, int h, int x, int y, int r)
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

typedef struct colouring {
    int by_rgb;
    double z_lo, z_hi;
} colouring;

/* Shaded colours of panel p into the image rectangle at (x0, y0). */
static void compose(const panel *p, const view *v, const colouring *col, const float *depth,
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
            double shade = edl_shade(depth, v->w, v->h, x, y, r);
            if (col->by_rgb) {
                memcpy(c, p->rgb + 3 * (size_t)src, 3);
            } else {
                double t = zspan > 0 ? (p->z[src] - col->z_lo) / zspan : 0.5;
                t = t > 0 ? (t < 1 ? t : 1) : 0;
                viridis(round(t * (RAMP_LEVELS - 1)) / (RAMP_LEVELS - 1), c);
                shade = round(shade * (SHADE_LEVELS - 1)) / (SHADE_LEVELS - 1);
            }
            uint8_t *o = img->rgb + 3 * ((size_t)(y0 + y) * img->width + (size_t)(x0 + x));
            for (int k = 0; k < 3; k++)
                o[k] = (uint8_t)lround(c[k] * shade);
        }
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

static int composite_panel(panel *p, const view *v, const colouring *col,
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
    compose(p, v, col, depth, from, img, x0, y0);
    free(depth);
    free(from);
    return 0;
}

/* Height ramp: 1st to 99th percentile of the heights visible in p. */
static int visible_height_range(const panel *p, const view *v, double *lo, double *hi,
                                wpd_error *err)
{
    size_t npix = (size_t)v->w * (size_t)v->h, n = 0;
    double *zs = malloc(npix * sizeof *zs);
    if (!zs)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the height ramp", p->path);
    for (size_t i = 0; i < npix; i++)
        if (isfinite(p->depth[i]))
            zs[n++] = p->z[i];
    qsort(zs, n, sizeof *zs, cmp_double);
    *lo = n ? quantile(zs, n, 0.01) : 0;
    *hi = n ? quantile(zs, n, 0.99) : 1;
    free(zs);
    return 0;
}

/* ---- histograms ---- */

static void put_pixel(wpd_preview_image *img, int x, int y, const uint8_t c[3])
{
    if (x < 0 || y < 0 || x >= img->width || y >= img->height)
        return;
    memcpy(img->rgb + 3 * ((size_t)y * img->width + x), c, 3);
}

static void fill_rect(wpd_preview_image *img, int x0, int y0, int x1, int y1, const uint8_t c[3])
{
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            put_pixel(img, x, y, c);
}

/* The spacing histogram of p over 0 .. hmax in the rectangle (x0, y0, w, h):
 * bars up from a baseline, ticks below it, the median as an orange line. */
static void draw_histogram(panel *p, double hmax, wpd_preview_image *img, int x0, int y0, int w,
                           int h)
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
        fill_rect(img, bx0, base - bh, bx1, base, bar_colour);
    }
    fill_rect(img, left, base, right + 1, base + 1, axis_colour);
    for (int t = 0; t <= 4; t++) {
        int x = left + (int)lround(t * (right - left) / 4.0);
        fill_rect(img, x, base + 1, x + 1, base + (t % 2 ? 5 : 8), axis_colour);
    }
    double med = p->info.spacing_median;
    if (med >= 0 && med <= hmax && hmax > 0) {
        int x = left + (int)lround(med / hmax * (right - left));
        fill_rect(img, x, top, x + 1, base, median_colour);
    }
}

/* ---- rendering ---- */

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

/* The candidate azimuth whose points fill the view rectangle best; the
 * preferred 30 degrees unless another fits at least 10 % larger (a long
 * strip seen end-on would waste most of the picture). */
static double choose_view(const panel *p, const double origin[3], int w, int h, view *v)
{
    int best = PREFERRED_AZIMUTH;
    double scale[AZIMUTHS];
    /* All scales first: comparing with scale[best] while filling the array
     * read scale[PREFERRED_AZIMUTH] before it was set (found by test-asan,
     * where the uninitialised stack value differed). */
    for (int a = 0; a < AZIMUTHS; a++)
        scale[a] = fit_scale(p->ext_hi[a][0] - p->ext_lo[a][0],
                             p->ext_hi[a][1] - p->ext_lo[a][1], w, h);
    for (int a = 0; a < AZIMUTHS; a++)
        if (scale[a] > scale[best])
            best = a;
    if (scale[PREFERRED_AZIMUTH] >= scale[best] / 1.1)
        best = PREFERRED_AZIMUTH;
    view_angles(v, best * AZIMUTH_STEP);
    double u0, v0, d0;
    project(v, origin, &u0, &v0, &d0);
    view_fit(v, best * AZIMUTH_STEP, p->ext_lo[best][0] - u0, p->ext_hi[best][0] - u0,
             p->ext_lo[best][1] - v0, p->ext_hi[best][1] - v0, w, h);
    return best * AZIMUTH_STEP;
}

/* One input's drawing pass and spacing, in the view v. */
static int draw_panel(panel *p, const view *v, const double origin[3], const double ext[3],
                      int by_rgb, wpd_batch *b, int threads, wpd_error *err)
{
    p->info.by_rgb = by_rgb;
    sample_layout(&p->sample, ext, p->info.points);
    if (panel_alloc(p, v, by_rgb, err) || draw_pass(p, v, origin, b, err) ||
        measure_spacing(p, threads, err))
        return -1;
    p->info.spacing_count = p->nspacing;
    p->info.spacing_median = quantile(p->spacing, p->nspacing, 0.5);
    p->info.spacing_p99 = quantile(p->spacing, p->nspacing, 0.99);
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
            rc = scan_pass(&pn[i], &b[i], err);
    }
    if (!rc) {
        col->by_rgb = 1;
        for (int i = 0; i < n; i++)
            col->by_rgb &= pn[i].rgb_denom > 0;
        for (int a = 0; a < 3; a++) {
            sum->origin[a] = pn[0].lo[a];
            sum->extent[a] = pn[0].hi[a] - pn[0].lo[a];
        }
        sum->azimuth = choose_view(&pn[0], sum->origin, lay->view_w, lay->view_h, v);
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
    if (visible_height_range(&pn[0], v, &col->z_lo, &col->z_hi, err))
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
        if (composite_panel(&pn[i], v, col, img, lay->col_x[i], 0, err))
            return -1;
    if (n < 2)
        return 0;
    double a = pn[0].info.spacing_p99, c = pn[1].info.spacing_p99;
    sum->hist_max = isnan(a) ? c : isnan(c) ? a : fmax(a, c);
    if (isnan(sum->hist_max))
        sum->hist_max = 0;
    for (int i = 0; i < n; i++)
        draw_histogram(&pn[i], sum->hist_max, img, lay->col_x[i], lay->hist_y, lay->view_w,
                       lay->hist_h);
    static const uint8_t rule[3] = {200, 200, 196};
    fill_rect(img, lay->view_w, 0, lay->col_x[1], img->height, rule);
    return 0;
}

static int render(panel *pn, int n, const wpd_preview_options *opt, wpd_preview_image *img,
                  wpd_preview_summary *sum, wpd_error *err)
{
    layout lay;
    make_layout(&lay, opt->width, opt->height, n);
    view v;
    memset(&v, 0, sizeof v);
    colouring col = {0, 0, 1};
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
    sum->width = opt->width;
    sum->height = opt->height;
    panel pn[2];
    memset(pn, 0, sizeof pn);
    int rc = 0;
    for (int i = 0; i < n && !rc; i++) {
        pn[i].path = paths[i];
        if (!(pn[i].cloud = wpd_cloud_open(&paths[i], 1, err)))
            rc = -1;
    }
    if (!rc)
        rc = render(pn, n, opt, img, sum, err);
    for (int i = 0; i < n; i++) {
        sum->panel[i] = pn[i].info;
        panel_free(&pn[i]);
    }
    if (rc)
        wpd_preview_image_free(img);
    return rc;
}

/* ---- PNG ---- */

typedef struct png_sink {
    uint8_t *data;
    size_t len, cap;
    char msg[200];
} png_sink;

static void sink_write(png_structp png, png_bytep data, png_size_t len)
{
    png_sink *s = png_get_io_ptr(png);
    if (s->len + len > s->cap) {
        size_t cap = s->cap ? s->cap : 1 << 16;
        while (cap < s->len + len)
            cap *= 2;
        uint8_t *grown = realloc(s->data, cap);
        if (!grown)
            png_error(png, "out of memory");
        s->data = grown;
        s->cap = cap;
    }
    memcpy(s->data + s->len, data, len);
    s->len += len;
}

static void sink_flush(png_structp png) { (void)png; }

static void sink_error(png_structp png, png_const_charp msg)
{
    png_sink *s = png_get_error_ptr(png);
    snprintf(s->msg, sizeof s->msg, "%s", msg);
    png_longjmp(png, 1);
}

static void sink_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* warnings do not change the output */
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* The image's distinct colours (0xRRGGBB, ascending) when there are at most
 * 256 of them: returns how many, or 0 when there are more (or no memory:
 * the caller then simply writes RGB). */
static int find_palette(const wpd_preview_image *img, uint32_t pal[256])
{
    uint8_t *seen = calloc((size_t)1 << 21, 1); /* one bit per 24-bit colour */
    if (!seen)
        return 0;
    int n = 0;
    size_t npix = (size_t)img->width * img->height;
    for (size_t i = 0; i < npix && n <= 256; i++) {
        const uint8_t *p = img->rgb + 3 * i;
        uint32_t c = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
        if (seen[c >> 3] & (1u << (c & 7)))
            continue;
        seen[c >> 3] |= (uint8_t)(1u << (c & 7));
        if (n < 256)
            pal[n] = c;
        n++;
    }
    free(seen);
    if (n > 256)
        return 0;
    qsort(pal, (size_t)n, sizeof *pal, cmp_u32);
    return n;
}

/* Palette indices of the image's pixels (every colour is in pal). */
static void index_pixels(const wpd_preview_image *img, const uint32_t *pal, int n, uint8_t *out)
{
    size_t npix = (size_t)img->width * img->height;
    for (size_t i = 0; i < npix; i++) {
        const uint8_t *p = img->rgb + 3 * i;
        uint32_t c = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
        int lo = 0, hi = n - 1;
        while (lo < hi) {
            int mid = (lo + hi) / 2;
            if (pal[mid] < c)
                lo = mid + 1;
            else
                hi = mid;
        }
        out[i] = (uint8_t)lo;
    }
}

/* libpng's part: writes rows (palette indices when npal > 0, else RGB) into
 * the sink. All state is set before setjmp, so a longjmp clobbers nothing.
 * Returns 0, or -1 with sink->msg set. */
static int png_encode_rows(png_sink *sink, png_bytep *rows, int w, int h, const png_color *plte,
                           int npal, png_text *text, int ntext)
{
    png_structp ps = png_create_write_struct(PNG_LIBPNG_VER_STRING, sink, sink_error, sink_warning);
    png_infop info = ps ? png_create_info_struct(ps) : NULL;
    if (!info) {
        png_destroy_write_struct(ps ? &ps : NULL, NULL);
        snprintf(sink->msg, sizeof sink->msg, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(ps))) {
        png_destroy_write_struct(&ps, &info);
        return -1;
    }
    png_set_write_fn(ps, sink, sink_write, sink_flush);
    png_set_compression_level(ps, 9);
    png_set_IHDR(ps, info, (png_uint_32)w, (png_uint_32)h, 8,
                 npal ? PNG_COLOR_TYPE_PALETTE : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (npal) {
        png_set_PLTE(ps, info, plte, npal);
        png_set_filter(ps, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE); /* indices: no prediction */
    }
    if (ntext > 0)
        png_set_text(ps, info, text, ntext);
    png_set_rows(ps, info, rows);
    png_write_png(ps, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&ps, &info);
    return 0;
}

int wpd_preview_encode_png(const wpd_preview_image *img, const char *const *keys,
                           const char *const *texts, int ntext, const char *name,
                           uint8_t **png, size_t *len, wpd_error *err)
{
    *png = NULL;
    *len = 0;
    png_sink sink;
    memset(&sink, 0, sizeof sink);
    uint32_t pal[256];
    int npal = find_palette(img, pal);
    size_t npix = (size_t)img->width * img->height;
    uint8_t *indexed = npal ? malloc(npix) : NULL;
    if (!indexed)
        npal = 0;
    png_bytep *rows = malloc((size_t)img->height * sizeof *rows);
    png_text *text = calloc((size_t)(ntext > 0 ? ntext : 1), sizeof *text);
    png_color plte[256];
    int rc = -1;
    if (!rows || !text) {
        snprintf(sink.msg, sizeof sink.msg, "out of memory");
        goto done;
    }
    if (npal) {
        index_pixels(img, pal, npal, indexed);
        for (int i = 0; i < npal; i++) {
            plte[i].red = (png_byte)(pal[i] >> 16);
            plte[i].green = (png_byte)(pal[i] >> 8);
            plte[i].blue = (png_byte)pal[i];
        }
    }
    for (int y = 0; y < img->height; y++)
        rows[y] = npal ? indexed + (size_t)y * img->width : img->rgb + (size_t)y * img->width * 3;
    for (int i = 0; i < ntext; i++) {
        text[i].compression = PNG_TEXT_COMPRESSION_NONE;
        text[i].key = (char *)keys[i];
        text[i].text = (char *)texts[i];
    }
    rc = png_encode_rows(&sink, rows, img->width, img->height, plte, npal, text, ntext);
done:
    free(rows);
    free(text);
    free(indexed);
    if (rc) {
        free(sink.data);
        if (!strcmp(sink.msg, "out of memory"))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory encoding the PNG", name);
        return wpd_fail(err, WPD_E_IO, "%s: PNG encoding failed: %s", name, sink.msg);
    }
    *png = sink.data;
    *len = sink.len;
    return 0;
}

/* ---- description, file output ---- */

/* v with 6 significant digits, or "n/a" for NaN. */
static const char *number(double v, char *buf, size_t len)
{
    if (isnan(v))
        snprintf(buf, len, "n/a");
    else
        snprintf(buf, len, "%.6g", v);
    return buf;
}

static void describe_panel(const wpd_preview_panel *p, const char *role, const char *path,
                           char *buf, size_t len)
{
    char colour[40], med[32], p99[32];
    if (!p->by_rgb)
        snprintf(colour, sizeof colour, "height");
    else if (p->rgb_bits)
        snprintf(colour, sizeof colour, "RGB (%d-bit)", p->rgb_bits);
    else
        snprintf(colour, sizeof colour, "RGB");
    snprintf(buf, len,
             "%s%s: %llu points, %llu drawn (every %llu), coloured by %s, point size %d px, "
             "nearest-neighbour spacing median %s p99 %s (%llu points measured)\n",
             role, path, (unsigned long long)p->points, (unsigned long long)p->drawn,
             (unsigned long long)p->stride, colour, p->point_size,
             number(p->spacing_median, med, sizeof med), number(p->spacing_p99, p99, sizeof p99),
             (unsigned long long)p->spacing_count);
}

void wpd_preview_describe(const wpd_preview_summary *s, const char *const *paths, char *buf,
                          size_t len)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int i = 0; i < s->panels && used < len; i++) {
        describe_panel(&s->panel[i], s->panels == 1 ? "" : i == 0 ? "before " : "after ",
                       paths[i], buf + used, len - used);
        used += strlen(buf + used);
    }
    if (used < len)
        snprintf(buf + used, len - used,
                 "view: azimuth %g deg, elevation %g deg, orthographic, %.6g px per unit, "
                 "origin %.9g %.9g %.9g, extent %.6g %.6g %.6g\n",
                 s->azimuth, WPD_PREVIEW_ELEVATION_DEG, s->scale, s->origin[0],
                 s->origin[1], s->origin[2], s->extent[0], s->extent[1], s->extent[2]);
    used += strlen(buf + used);
    if (used < len && !s->panel[0].by_rgb)
        snprintf(buf + used, len - used,
                 "height ramp (viridis, dark to yellow): z %.6g .. %.6g\n",
                 s->origin[2] + s->z_lo, s->origin[2] + s->z_hi);
    used += strlen(buf + used);
    if (used < len && s->panels == 2)
        snprintf(buf + used, len - used,
                 "histograms: nearest-neighbour spacing, %d bins, axis 0 .. %.6g (ticks every "
                 "%.6g), bars scaled to each peak, orange line = median; beyond the axis: "
                 "before %llu, after %llu\n",
                 WPD_PREVIEW_HIST_BINS, s->hist_max, s->hist_max / 4,
                 (unsigned long long)s->panel[0].hist_beyond,
                 (unsigned long long)s->panel[1].hist_beyond);
}

int wpd_preview_write(const char *const *paths, int n, const char *out,
                      const wpd_preview_options *opt, wpd_preview_summary *summary,
                      wpd_error *err)
{
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

/* ---- the subcommand ---- */

static const char *usage_text =
    "usage: wpd preview FILE -o OUT.png [--width W] [--height H] [--force]\n"
    "       wpd preview BEFORE AFTER -o OUT.png [--width W] [--height H] [--force]\n"
    "Draws a LAS or PLY point cloud as a PNG: an oblique orthographic view\n"
    "(azimuth 30, elevation 35 degrees) fitted to the image, coloured by the\n"
    "file's RGB when it has any, else by height (viridis). With two files, the\n"
    "two side by side in the same view and scale (BEFORE's bounds), each above\n"
    "a histogram of its nearest-neighbour spacing on a common axis (0 .. the\n"
    "larger 99th percentile; ticks at quarters, orange line = median). Point\n"
    "counts, axis range and colour range are printed and stored in the PNG's\n"
    "tEXt chunk. Memory does not depend on the input's size.\n"
    "  -o, --output FILE   the PNG to write; must not exist unless --force\n"
    "      --width W       image width in pixels (default 1200)\n"
    "      --height H      image height in pixels (default 700)\n"
    "      --force         replace OUT if it exists\n"
    "  -q, --quiet         print nothing on success\n";

static int parse_side(const char *text, int *out)
{
    char *end;
    long v = strtol(text, &end, 10);
    if (end == text || *end || v < WPD_PREVIEW_MIN_SIDE || v > WPD_PREVIEW_MAX_SIDE)
        return -1;
    *out = (int)v;
    return 0;
}

int wpd_preview_main(int argc, char **argv)
{
    enum { OPT_WIDTH = 256, OPT_HEIGHT, OPT_FORCE };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"width", required_argument, 0, OPT_WIDTH},
        {"height", required_argument, 0, OPT_HEIGHT}, {"force", no_argument, 0, OPT_FORCE},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    const char *out = NULL;
    int quiet = 0, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': out = optarg; break;
        case 'q': quiet = 1; break;
        case OPT_FORCE: opt.overwrite = 1; break;
        case 'h': fputs(usage_text, stdout); return 0;
        case OPT_WIDTH:
        case OPT_HEIGHT:
            if (parse_side(optarg, c == OPT_WIDTH ? &opt.width : &opt.height)) {
                fprintf(stderr, "wpd preview: --%s '%s': expected a whole number of pixels "
                        "%d..%d\n", c == OPT_WIDTH ? "width" : "height", optarg,
                        WPD_PREVIEW_MIN_SIDE, WPD_PREVIEW_MAX_SIDE);
                return WPD_E_USAGE;
            }
            break;
        default:
            if (optopt)
                fprintf(stderr, "wpd preview: option '-%c' %s (see 'wpd preview --help')\n",
                        optopt, strchr("o", optopt) ? "needs a value" : "is unknown");
            else
                fprintf(stderr, "wpd preview: unknown option '%s' or missing value (see 'wpd "
                        "preview --help')\n", argv[optind - 1]);
            return WPD_E_USAGE;
        }
    }
    int n = argc - optind;
    if (n < 1 || n > 2) {
        fprintf(stderr, "wpd preview: expected FILE or BEFORE AFTER, got %d file%s "
                "(see 'wpd preview --help')\n", n, n == 1 ? "" : "s");
        return WPD_E_USAGE;
    }
    if (!out) {
        fprintf(stderr, "wpd preview: no output: give -o OUT.png\n");
        return WPD_E_USAGE;
    }
    const char *const *paths = (const char *const *)argv + optind;
    wpd_error err = {0};
    wpd_preview_summary sum;
    if (wpd_preview_write(paths, n, out, &opt, &sum, &err)) {
        fprintf(stderr, "wpd preview: %s\n", err.msg[0] ? err.msg : "failed");
        return err.code ? (int)err.code : WPD_E_IO;
    }
    if (!quiet) {
        char text[4096];
        wpd_preview_describe(&sum, paths, text, sizeof text);
        printf("%swrote %s (%d x %d)\n", text, out, sum.width, sum.height);
        if (fflush(stdout) || ferror(stdout))
            return WPD_E_IO;
    }
    return 0;
}
