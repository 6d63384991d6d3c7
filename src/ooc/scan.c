#include "ooc/scan.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/voxel_set.h"

/* Voxel keys pack 21 bits per axis: indices relative to the origin. */
enum { KEY_BITS = 21 };
#define KEY_MASK ((1ull << KEY_BITS) - 1)

static uint64_t pack(uint64_t ix, uint64_t iy, uint64_t iz)
{
    return ix | iy << KEY_BITS | iz << (2 * KEY_BITS);
}

/* The key of the voxel twice as large that contains voxel key. */
static uint64_t coarser(uint64_t key)
{
    return pack((key & KEY_MASK) >> 1, ((key >> KEY_BITS) & KEY_MASK) >> 1,
                (key >> (2 * KEY_BITS)) >> 1);
}

/* Replaces set by the set of its voxels' parents. */
static int coarsen(wpd_voxel_set *set)
{
    wpd_voxel_set next;
    size_t cap = 1024;
    while (cap < set->count)
        cap <<= 1;
    if (wpd_voxel_set_init(&next, cap) < 0)
        return -1;
    for (size_t i = 0; i < set->cap; i++)
        if (set->slot[i] != WPD_VOXEL_KEY_EMPTY && wpd_voxel_set_put(&next, coarser(set->slot[i])))
            return wpd_voxel_set_free(&next), -1;
    wpd_voxel_set_free(set);
    *set = next;
    return 0;
}

/* State of pass 2. */
typedef struct voxel_ladder {
    wpd_voxel_set set;
    double edge, inv;         /* current voxel edge */
    int level;                /* coarsenings so far */
    size_t cap;               /* keys allowed before coarsening */
    uint64_t last;            /* last key put: scans repeat voxels */
} voxel_ladder;

static int ladder_put(voxel_ladder *v, const double p[3])
{
    uint64_t ix = (uint64_t)(p[0] * v->inv), iy = (uint64_t)(p[1] * v->inv),
             iz = (uint64_t)(p[2] * v->inv);
    uint64_t key = pack(ix & KEY_MASK, iy & KEY_MASK, iz & KEY_MASK);
    if (key == v->last)
        return 0;
    v->last = key;
    if (wpd_voxel_set_put(&v->set, key))
        return -1;
    while (v->set.count > v->cap) {
        if (coarsen(&v->set))
            return -1;
        v->edge *= 2;
        v->inv = 1.0 / v->edge;
        v->level++;
        v->last = WPD_VOXEL_KEY_EMPTY;
    }
    return 0;
}

size_t wpd_scan_cell_of(const wpd_scan *s, const double p[3])
{
    size_t c[3];
    for (int a = 0; a < 3; a++) {
        double f = p[a] * s->inv_cell;
        long i = f < 0 ? 0 : (long)f;
        c[a] = (size_t)(i >= s->dim[a] ? s->dim[a] - 1 : i);
    }
    return c[0] + (size_t)s->dim[0] * (c[1] + (size_t)s->dim[1] * c[2]);
}

static int bounds_pass(wpd_cloud *cloud, wpd_scan *s, wpd_error *err)
{
    wpd_batch b;
    if (wpd_batch_init(&b, 65536, wpd_cloud_header(cloud, 0)->schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_bounds box;
    wpd_bounds_reset(&box);
    long got;
    int file;
    int rc = wpd_cloud_rewind(cloud, err);
    while (rc == 0 && (got = wpd_cloud_read(cloud, &b, &file, err)) > 0) {
        wpd_bounds_add(&box, b.xyz, b.n);
        s->file_count[file] += b.n;
    }
    wpd_batch_free(&b);
    if (rc || got < 0)
        return -1;
    if (box.count == 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates",
                        wpd_cloud_header(cloud, 0)->path);
    s->count = box.count;
    for (int a = 0; a < 3; a++) {
        s->origin[a] = box.min[a];
        s->extent[a] = box.max[a] - box.min[a];
    }
    return 0;
}

static void init_grid(wpd_scan *s)
{
    double longest = fmax(s->extent[0], fmax(s->extent[1], s->extent[2]));
    s->cell = longest > 0 ? longest / WPD_SCAN_GRID * (1 + 1e-9) : 1.0;
    s->inv_cell = 1.0 / s->cell;
    for (int a = 0; a < 3; a++) {
        s->dim[a] = (int)floor(s->extent[a] / s->cell) + 1;
        if (s->dim[a] > WPD_SCAN_GRID)
            s->dim[a] = WPD_SCAN_GRID;
    }
}

/* Counts of the final set and of every coarser scale, finest first. */
static int finish_ladder(voxel_ladder *v, wpd_scan *s)
{
    s->nscales = 0;
    double edge = v->edge;
    while (s->nscales < WPD_MAX_SCALES) {
        s->edge[s->nscales] = edge;
        s->voxels[s->nscales] = v->set.count;
        s->nscales++;
        if (v->set.count <= 1)
            break;
        if (coarsen(&v->set))
            return -1;
        edge *= 2;
    }
    return 0;
}

static int scan_pass(wpd_cloud *cloud, wpd_scan *s, size_t voxel_cap, wpd_error *err)
{
    double longest = fmax(s->extent[0], fmax(s->extent[1], s->extent[2]));
    voxel_ladder v = {.cap = voxel_cap < 1024 ? 1024 : voxel_cap, .last = WPD_VOXEL_KEY_EMPTY};
    /* Start at the scale where the bounding box's largest face would fill
     * half the cap (a surface scene), never finer than 2^16 voxels along
     * the longest axis nor than one voxel per point; walls and vegetation
     * make the set larger, and the cap coarsens it. Starting much finer
     * only costs cache misses: on the NC Raleigh scan 2^16 cost 1.3 s. */
    double e[3] = {s->extent[0], s->extent[1], s->extent[2]};
    double face = fmax(e[0] * e[1], fmax(e[0] * e[2], e[1] * e[2]));
    double keys = fmin((double)v.cap / 2, (double)s->count);
    v.edge = fmax(longest / 65536.0, sqrt(face / fmax(keys, 1)));
    if (!(v.edge > 0))
        v.edge = 1.0;
    v.inv = 1.0 / v.edge;
    wpd_batch b;
    if (wpd_voxel_set_init(&v.set, 4096) ||
        wpd_batch_init(&b, 65536, wpd_cloud_header(cloud, 0)->schema.record_size)) {
        wpd_voxel_set_free(&v.set);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    }
    long got;
    int rc = wpd_cloud_rewind(cloud, err);
    while (rc == 0 && (got = wpd_cloud_read(cloud, &b, NULL, err)) > 0) {
        for (size_t i = 0; i < b.n && rc == 0; i++) {
            double p[3];
            for (int a = 0; a < 3; a++)
                p[a] = b.xyz[3 * i + a] - s->origin[a];
            s->density[wpd_scan_cell_of(s, p)]++;
            if (ladder_put(&v, p))
                rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
        }
    }
    if (rc == 0 && got < 0)
        rc = -1;
    if (rc == 0 && finish_ladder(&v, s))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    wpd_batch_free(&b);
    wpd_voxel_set_free(&v.set);
    return rc;
}

int wpd_scan_run(wpd_cloud *cloud, size_t voxel_cap, wpd_scan *out, wpd_error *err)
{
    memset(out, 0, sizeof *out);
    out->nfiles = wpd_cloud_nfiles(cloud);
    out->file_count = calloc((size_t)out->nfiles, sizeof *out->file_count);
    if (!out->file_count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    double t = omp_get_wtime();
    if (bounds_pass(cloud, out, err))
        goto fail;
    out->bounds_seconds = omp_get_wtime() - t;
    t = omp_get_wtime();
    init_grid(out);
    out->density = calloc((size_t)out->dim[0] * out->dim[1] * out->dim[2], sizeof *out->density);
    if (!out->density) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the density grid");
        goto fail;
    }
    if (scan_pass(cloud, out, voxel_cap, err) || wpd_cloud_rewind(cloud, err))
        goto fail;
    out->scan_seconds = omp_get_wtime() - t;
    return 0;
fail:
    wpd_scan_free(out);
    return -1;
}

void wpd_scan_free(wpd_scan *s)
{
    free(s->file_count);
    free(s->density);
    memset(s, 0, sizeof *s);
}
