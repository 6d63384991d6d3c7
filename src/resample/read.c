/* read.c - the inputs of a run (read.h). */
#include "resample/read.h"

wpd_cloud *wpd_read_open(char *const *inputs, int ninputs, const char *tmpdir, wpd_error *err)
{
    wpd_cloud *cloud = wpd_cloud_open((const char *const *)inputs, ninputs, err);
    if (cloud && wpd_cloud_cache_records(cloud, tmpdir, err)) {
        wpd_cloud_close(cloud);
        return NULL;
    }
    return cloud;
}
