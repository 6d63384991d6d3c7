/* params.c - the defaults of params.h. */
#include "method/params.h"

#include <string.h>

#include "method/radius.h"
#include "method/smooth.h"

void wpd_params_default(wpd_params *p)
{
    memset(p, 0, sizeof *p);
    p->lambda = 0.68;
    p->voxel_frac = 0.05;
    p->radius_method = WPD_RADIUS_MULTISCALE;
    p->density = WPD_MULTISCALE_DENSITY;
    p->max_passes = 40;
    p->k = 13;
    p->iterations = 5;
    p->even_iterations = 4;
    p->smooth = 1;
    p->sharp = 0;
    p->seed = 0;
    p->threads = 0;
}
