/* merge.c - the samples of all tiles in global-index order (the output
 * order, whatever the tiling and the threads), in absolute coordinates. */
#include "resample/flat.h"

#include <stdlib.h>

int wpd_merge_phase(wpd_run *run, wpd_error *err)
{
    wpd_resample_result *res = run->res;
    wpd_flat f = {0};
    for (int t = 0; t < run->plan.ntiles; t++)
        if (wpd_store_load(run, t, err))
            return -1;
    if (wpd_flat_from_store(run, &f)) {
        wpd_flat_free(&f);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory merging %zu samples",
                        wpd_run_store_count(run));
    }
    wpd_run_store_clear(run);
    for (size_t j = 0; j < f.n; j++)
        for (int a = 0; a < 3; a++)
            f.xyz[3 * j + a] += run->scan.origin[a];
    res->count = f.n;
    res->gid = f.gid;
    res->xyz = f.xyz;
    res->edge = f.edge;
    free(f.tile);
    return 0;
}
