/* params.h - the method's parameters (paper: lambda, voxel size, k,
 * iterations; ours: the multiscale radius, smoothing mode, surface
 * projection, sharp features, output lattice, seed, threads). */
#ifndef WPD_PARAMS_H
#define WPD_PARAMS_H

#include <stdint.h>

typedef enum wpd_radius_method {
    WPD_RADIUS_PAPER = 0,     /* paper eq. 3-4: one voxel scale, voxel_frac x extent */
    WPD_RADIUS_MULTISCALE = 1 /* voxels counted at the scale of r itself (radius.h) */
} wpd_radius_method;

typedef struct wpd_params {
    double lambda;            /* overlap factor of eq. 1 (0.68) */
    double voxel_frac;        /* voxel edge / largest extent (0.05) */
    wpd_radius_method radius_method; /* WPD_RADIUS_MULTISCALE */
    double density;           /* multiscale: samples per occupied r-voxel */
    double radius;            /* > 0: start from this radius, no estimate
                                 (an engine's global radius) */
    int max_passes;           /* refinement passes at most (40) */
    int k;                    /* neighbours for normals and smoothing (13) */
    int iterations;           /* smoothing iterations (5) */
    int even_iterations;      /* even-spacing steps, alternated with them (4; smooth_even.h) */
    int smooth;               /* 1: weighted tangent smoothing (on) */
    int sharp;                /* 1: detect sharp features, sample them at r/2 (off) */
    double resolution[3];     /* the output stores coordinates as multiples of these
                                 per axis in the block frame (a LAS scale, when the
                                 block's origin is an input point); 0: exact (0) */
    uint64_t seed;            /* visiting order (0) */
    int threads;              /* OpenMP threads inside the block; <= 0: default */
} wpd_params;

/* Fills p with the defaults above. */
void wpd_params_default(wpd_params *p);

/* Whether a run with p moves its samples at all: smoothing on, with some
 * Voronoi or even-spacing step to take. */
static inline int wpd_params_smooths(const wpd_params *p)
{
    return p->smooth && p->iterations + p->even_iterations > 0;
}

#endif
