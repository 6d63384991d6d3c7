/* edges.h - `wpd edges`: the sharp-feature detector of `wpd resample
 * --sharp` (method/sharp.h) on every point of a cloud, to measure it and to
 * look at it.
 *
 *   wpd edges IN [--cap R] [--truth DIM] [-o OUT] [--threads T] [--force]
 *
 * Labels each finite point of IN (several inputs are one cloud) with the
 * detector, its neighbourhoods capped at R (default: none; `wpd resample`
 * caps them at its radius estimate, printed by `wpd resample -v`), in the
 * frame whose origin is the minimum corner of the points, as resample's.
 * Prints the points, those labelled and their share, and the time. With
 * --truth DIM (e.g. synth's edge_truth): DIM not 0 is the truth; prints
 * precision, recall, the recall per value of DIM and, for the truth points
 * missed, why (the crease test's verdicts). With -o OUT: writes the points
 * of IN with the label as the field "edge" (as resample --edge-label).
 * The cloud is held in memory (coordinates, a grid, the labels): about 60
 * bytes per point.
 */
#ifndef WPD_TOOLS_EDGES_H
#define WPD_TOOLS_EDGES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

/* What a labelling measured. */
typedef struct wpd_edges_summary {
    uint64_t points, labelled;
    int with_truth;
    uint64_t truth, true_positive;          /* truth points; labelled among them */
    uint64_t truth_by_value[256], hit_by_value[256];
    uint64_t missed_by_verdict[16];        /* truth points not labelled, by verdict */
    uint64_t by_verdict[16];               /* every point, by its verdict (wpd_sharp_verdicts) */
    double seconds;                        /* the detector alone */
} wpd_edges_summary;

/* The subcommand: argv[0] = "edges". Returns the exit status. */
int wpd_edges_main(int argc, char **argv);

#endif
