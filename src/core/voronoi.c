/* voronoi.c - clipping a square by perpendicular bisectors. */
#include "core/voronoi.h"

#include <math.h>
#include <string.h>

#define FRAME_EDGE (-1)
#define POLY_MAX WPD_VORONOI_MAX_VERTS

typedef struct polygon {
    int n;
    double x[POLY_MAX], y[POLY_MAX];
    int label[POLY_MAX]; /* line carrying the edge from vertex i to i+1 */
} polygon;

/* Writes to out the part of poly with a*x + b*y <= c; the new edge gets
 * `label`. (Two polygons swapped by the caller: a clip copies only the
 * vertices it keeps.) */
static void clip(const polygon *poly, polygon *out, double a, double b, double c, int label)
{
    out->n = 0;
    int n = poly->n;
    for (int i = 0; i < n; i++) {
        int j = i + 1 == n ? 0 : i + 1;
        double si = a * poly->x[i] + b * poly->y[i] - c;
        double sj = a * poly->x[j] + b * poly->y[j] - c;
        int in_i = si <= 0, in_j = sj <= 0;
        if (in_i) {
            out->x[out->n] = poly->x[i];
            out->y[out->n] = poly->y[i];
            out->label[out->n++] = poly->label[i];
        }
        if (in_i != in_j && out->n < POLY_MAX) {
            double t = si / (si - sj);
            out->x[out->n] = poly->x[i] + t * (poly->x[j] - poly->x[i]);
            out->y[out->n] = poly->y[i] + t * (poly->y[j] - poly->y[i]);
            /* Leaving: the boundary continues along the clip line. Entering:
             * it continues along the edge that was cut. */
            out->label[out->n++] = in_i ? label : poly->label[i];
        }
    }
}

void wpd_voronoi_cell_2d(const double *q, int m, double frame, wpd_voronoi_cell *cell)
{
    if (m > WPD_VORONOI_MAX_NB)
        m = WPD_VORONOI_MAX_NB;
    /* Only what the neighbours can label is cleared: the cell is large
     * and built for every sample in every smoothing iteration. */
    cell->closed = cell->nverts = 0;
    cell->area = 0;
    cell->centroid[0] = cell->centroid[1] = 0;
    memset(cell->edge, 0, (size_t)(m > 0 ? m : 0) * sizeof *cell->edge);
    if (frame <= 0) { /* the largest |q_j| */
        double f2 = 0;
        for (int j = 0; j < m; j++) {
            double d2 = q[2 * j] * q[2 * j] + q[2 * j + 1] * q[2 * j + 1];
            f2 = d2 > f2 ? d2 : f2;
        }
        frame = sqrt(f2);
    }
    if (!(frame > 0))
        return;
    polygon buf[2];
    polygon *poly = &buf[0], *spare = &buf[1];
    *poly = (polygon){4, {-frame, frame, frame, -frame}, {-frame, -frame, frame, frame},
                      {FRAME_EDGE, FRAME_EDGE, FRAME_EDGE, FRAME_EDGE}};
    double tiny = 1e-24 * frame * frame;
    double reach2 = 2 * frame * frame; /* squared distance of the farthest vertex */
    for (int j = 0; j < m && poly->n > 0; j++) {
        double qx = q[2 * j], qy = q[2 * j + 1];
        double q2 = qx * qx + qy * qy;
        if (q2 <= tiny)
            continue;
        /* The bisector of q lies |q| / 2 from the origin: it cannot cut a
         * polygon whose vertices are all nearer (usual after the nearest
         * neighbours, which come first in kNN order). */
        if (0.25 * q2 >= reach2)
            continue;
        clip(poly, spare, qx, qy, 0.5 * q2, j);
        polygon *t = poly;
        poly = spare;
        spare = t;
        reach2 = 0;
        for (int i = 0; i < poly->n; i++) {
            double v2 = poly->x[i] * poly->x[i] + poly->y[i] * poly->y[i];
            reach2 = v2 > reach2 ? v2 : reach2;
        }
    }
    if (poly->n < 3)
        return;
    cell->closed = 1;
    cell->nverts = poly->n;
    double area2 = 0, cx = 0, cy = 0;
    for (int i = 0; i < poly->n; i++) {
        int k = i + 1 == poly->n ? 0 : i + 1;
        double ex = poly->x[k] - poly->x[i], ey = poly->y[k] - poly->y[i];
        double cross = poly->x[i] * poly->y[k] - poly->x[k] * poly->y[i];
        area2 += cross;
        cx += (poly->x[i] + poly->x[k]) * cross;
        cy += (poly->y[i] + poly->y[k]) * cross;
        cell->vx[i] = poly->x[i];
        cell->vy[i] = poly->y[i];
        if (poly->label[i] == FRAME_EDGE)
            cell->closed = 0;
        else
            cell->edge[poly->label[i]] += sqrt(ex * ex + ey * ey);
    }
    cell->area = 0.5 * fabs(area2);
    if (area2 != 0) {
        cell->centroid[0] = cx / (3 * area2);
        cell->centroid[1] = cy / (3 * area2);
    }
}
