/* las_audit.c - what the points of a LAS file say about its header.
 *
 * A header's bounds and points-by-return counts are summaries that many
 * writers get wrong (never updated after an edit, left at 0). No point is
 * read through them: wpd's writers recompute both, and the engine takes the
 * header bounds as its frame only when the points agree (cloud.h,
 * wpd_bounds_tight). So they are checked only where every point is read
 * anyway, by `wpd info`, and a disagreement is a warning.
 */
#include "io/las/las_internal.h"

#include <math.h>
#include <stdio.h>

void wpd_las_tally_returns(const wpd_header *h, const uint8_t *rec, size_t n,
                           uint64_t by_return[16])
{
    const uint32_t len = h->las.record_length;
    const uint8_t mask = (uint8_t)((1u << las_return_bits(h->las.pdrf)) - 1);
    /* Four tallies taken in turn: most points share a return number, and
     * one tally would make every increment wait for the one before. */
    uint64_t part[4][16] = {{0}};
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        const uint8_t *r = rec + i * len + 14;
        part[0][r[0] & mask]++;
        part[1][r[len] & mask]++;
        part[2][r[2 * (size_t)len] & mask]++;
        part[3][r[3 * (size_t)len] & mask]++;
    }
    for (; i < n; i++)
        part[0][rec[i * len + 14] & mask]++;
    for (int k = 0; k < 16; k++)
        by_return[k] += part[0][k] + part[1][k] + part[2][k] + part[3][k];
}

/* Appends " x header [lo, hi] points [lo, hi]" to out for each axis on
 * which the header bounds and the points differ by more than one step of
 * the coordinate grid (the scale). Returns the number of such axes. */
static int describe_bounds_mismatch(const wpd_header *h, const wpd_bounds *b, char *out,
                                    size_t cap)
{
    static const char axis[3] = {'x', 'y', 'z'};
    const wpd_las_info *las = &h->las;
    int bad = 0;
    size_t used = 0;
    for (int a = 0; a < 3; a++) {
        double step = fabs(las->scale[a]);
        if (fabs(las->min[a] - b->min[a]) <= step && fabs(las->max[a] - b->max[a]) <= step)
            continue;
        int k = snprintf(out + used, cap - used, " %c header [%.10g, %.10g] points [%.10g, %.10g]",
                         axis[a], las->min[a], las->max[a], b->min[a], b->max[a]);
        if (k > 0 && (size_t)k < cap - used)
            used += (size_t)k;
        bad++;
    }
    return bad;
}

/* Writes the counts c[0..n) as "a b c" into out. */
static void list_counts(const uint64_t *c, int n, char *out, size_t cap)
{
    size_t used = 0;
    out[0] = '\0';
    for (int i = 0; i < n && used < cap; i++) {
        int k = snprintf(out + used, cap - used, i ? " %llu" : "%llu", (unsigned long long)c[i]);
        if (k < 0)
            break;
        used += (size_t)k;
    }
}

/* Compares the header's points-by-return counts (5 of them before LAS 1.4,
 * 15 in 1.4) with the tally of the points' return numbers. */
static void check_returns(const wpd_header *h, const uint64_t by_return[16], wpd_warnings *w)
{
    int bins = h->las.version_minor >= 4 ? 15 : 5, shown = 0, same = 1;
    for (int i = 0; i < bins; i++) {
        same &= h->las.points_by_return[i] == by_return[i + 1];
        if (h->las.points_by_return[i] || by_return[i + 1])
            shown = i + 1; /* up to the last non-zero count of either */
    }
    if (same)
        return;
    char header[320], points[320], zero[64] = "";
    list_counts(h->las.points_by_return, shown, header, sizeof header);
    list_counts(by_return + 1, shown, points, sizeof points);
    if (by_return[0])
        snprintf(zero, sizeof zero, "; %llu have return number 0",
                 (unsigned long long)by_return[0]);
    wpd_warn(w,
             "%s: the header's points by return (%s) disagree with the points' return "
             "numbers (%s%s); ignored (LAS output recomputes them)",
             h->path, header, points, zero);
}

void wpd_las_check_header_against_points(const wpd_header *h, const wpd_bounds *b,
                                         const uint64_t by_return[16], wpd_warnings *w)
{
    if (h->format != WPD_FMT_LAS)
        return;
    char where[400];
    if (b->count && describe_bounds_mismatch(h, b, where, sizeof where))
        wpd_warn(w, "%s: the header bounds disagree with the points:%s; wpd uses the points'",
                 h->path, where);
    check_returns(h, by_return, w);
}
