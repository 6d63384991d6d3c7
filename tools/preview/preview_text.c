/* preview_text.c - the description of a `wpd preview` picture: per input
 * the counts, stride, colouring, point size and spacing, then the view,
 * the height ramp and the histogram axis; printed and stored in tEXt.
 */
#include "tools/preview/preview_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

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
                           const char *label, char *buf, size_t len)
{
    char colour[128], med[32], p99[32];
    if (label)
        snprintf(colour, sizeof colour, "%s (red: %llu drawn points not 0; grey by height)",
                 label, (unsigned long long)p->labelled);
    else if (!p->by_rgb)
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
    const char *label = s->label[0] ? s->label : NULL;
    size_t used = 0;
    buf[0] = '\0';
    for (int i = 0; i < s->panels && used < len; i++) {
        describe_panel(&s->panel[i], s->panels == 1 ? "" : i == 0 ? "before " : "after ",
                       paths[i], label, buf + used, len - used);
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
        snprintf(buf + used, len - used, "height ramp (%s): z %.6g .. %.6g\n",
                 label ? "grey, dark to light" : "viridis, dark to yellow",
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
