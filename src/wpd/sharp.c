/* sharp.c - surface-variation edge detector. */
#include "wpd/sharp.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/knn.h"
#include "core/pca.h"

void wpd_detect_sharp(const wpd_grid *surface, size_t n, int k, double threshold,
                      uint8_t *edge, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    if (k < 3)
        k = 3;
    if (k > WPD_KNN_MAX)
        k = WPD_KNN_MAX;
    /* Visit slots (cell order, cache friendly) and write by source index. */
    size_t slots = surface->n;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1024)
    for (size_t s = 0; s < slots; s++) {
        uint32_t id = surface->id[s];
        if (id >= n)
            continue;
        uint32_t near[WPD_KNN_MAX];
        /* k nearest including the point itself (distance 0 comes first). */
        int got = wpd_knn_slots(surface, surface->xyz + 3 * s, k, WPD_NO_SELF, INFINITY, 0,
                                near, NULL);
        double pts[3 * WPD_KNN_MAX];
        for (int j = 0; j < got; j++)
            memcpy(pts + 3 * j, surface->xyz + 3 * (size_t)near[j], 3 * sizeof(double));
        wpd_plane pl;
        wpd_plane_fit(pts, NULL, got, &pl);
        edge[id] = got >= 3 && pl.variation > threshold;
    }
}
