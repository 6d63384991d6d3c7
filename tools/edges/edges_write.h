/* edges_write.h - `wpd edges -o OUT`: the labelled cloud written out. */
#ifndef WPD_TOOLS_EDGES_WRITE_H
#define WPD_TOOLS_EDGES_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/cloud.h"

/* Refuses (WPD_E_USAGE) an output that is one of the inputs, has an
 * unknown extension, or exists without overwrite. Returns 0 or -1. */
int wpd_edges_check_output(const char *out, char *const *inputs, int n, int overwrite,
                           wpd_error *err);

/* Writes the n finite points of cloud (read again from its start) to out
 * with edge[i] as the field "edge". Returns 0 or -1 with err set. */
int wpd_edges_write(wpd_cloud *cloud, const uint8_t *edge, size_t n, const char *out,
                    int overwrite, wpd_error *err);

#endif
