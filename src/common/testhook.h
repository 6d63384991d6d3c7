/* testhook.h - fault-injection points and settings for the end-to-end
 * tests.
 *
 * With WPD_TEST_STALL=<name> in the environment, the process stops at the
 * point of that name (printing "wpd: stalled at <name>" on stderr) and waits
 * for a signal, so a test can kill it at a known moment. The points of a
 * `wpd resample` run, in the order it meets them: "scan" (the output is
 * locked, nothing read yet), "tile" (the first points are spilled),
 * "poisson", "exact", "smooth" and "merge" (the start of those phases),
 * "records" (the samples are in their runs, the records pass is about to
 * read), "write" (the temporary output exists; every command that writes a
 * file meets it), "per-input" (every --per-input output is complete under
 * its temporary name, none renamed yet), and a collection's commit
 * (resample/collection.h): "commit" (the new state written beside the
 * old one, not renamed) and "renames" (committed, the outputs not renamed;
 * signals are held back there: only SIGKILL ends the wait). Without the
 * variable it costs one getenv per call. */
#ifndef WPD_TESTHOOK_H
#define WPD_TESTHOOK_H

void wpd_test_stall(const char *name);

/* A number the tests may set through the environment variable var (a
 * decimal from 1 to max), else fallback: e.g. WPD_TEST_LAZ_CHUNK, the
 * points per LAZ chunk, so a test can compare chunks of 1 or 2 points with
 * LASzip's. A value that is not such a number is ignored. */
unsigned long wpd_test_number(const char *var, unsigned long fallback, unsigned long max);

#endif
