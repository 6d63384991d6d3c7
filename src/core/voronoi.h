/* voronoi.h - the Voronoi cell of one point among its neighbours, in its
 * tangent plane: its area centroid, where smoothing moves the point, and
 * the edge lengths that give the cotangent weights of paper eq. 7-8.
 *
 * The point sits at the origin of the plane; its neighbours are 2-D points
 * q_j. The cell starts as a square frame and is clipped by the perpendicular
 * bisector of every (origin, q_j). An edge of the final cell that lies on
 * the bisector of q_j makes j a Voronoi neighbour with weight
 *   w_j = |edge_j| / |q_j|  ( = (cot alpha + cot beta) / 2 ).
 * A cell that still touches the frame is open: its point lies on a boundary
 * of the sampling, where the weighted average would pull it inwards.
 *
 * Note on eq. 8: for a closed cell the edges e_j with outward unit normals
 * q_j / |q_j| close up, sum_j e_j q_j / |q_j| = 0, so the cotangent-weighted
 * average of the neighbours is the point itself (the cotangent Laplacian
 * reproduces linear functions): taken literally, eq. 8 never moves a point
 * within its tangent plane. The Lloyd / CVT step the paper builds on moves
 * it to the area centroid of its cell instead, and so does wpd.
 */
#ifndef WPD_CORE_VORONOI_H
#define WPD_CORE_VORONOI_H

#define WPD_VORONOI_MAX_NB 64

#define WPD_VORONOI_MAX_VERTS (WPD_VORONOI_MAX_NB + 8)

typedef struct wpd_voronoi_cell {
    int closed;                          /* 0: the cell touches the frame */
    double area;                         /* area of the (clipped) cell */
    double centroid[2];                  /* its area centroid */
    int nverts;
    double vx[WPD_VORONOI_MAX_VERTS], vy[WPD_VORONOI_MAX_VERTS]; /* counter-clockwise,
                                                                    [nverts] */
    double edge[WPD_VORONOI_MAX_NB];     /* [m] edge length on each bisector; the
                                            entries past m are not written */
} wpd_voronoi_cell;

/* Computes the cell of the origin among m (<= WPD_VORONOI_MAX_NB) neighbours
 * q[2j], q[2j+1]. frame is the half-width of the initial square; <= 0 means
 * the largest |q_j|. Neighbours at the origin itself are ignored. */
void wpd_voronoi_cell_2d(const double *q, int m, double frame, wpd_voronoi_cell *cell);


#endif
