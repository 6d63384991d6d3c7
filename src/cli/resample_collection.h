/* resample_collection.h - `wpd resample`'s collections (resample/collection.h,
 * docs/ingest.md) as the command sees them: the options turned into a
 * night's request, the recovery's and the night's lines, the night's
 * outputs (an --append output made from OUT and the night's samples)
 * handed to the commit. */
#ifndef WPD_CLI_RESAMPLE_COLLECTION_H
#define WPD_CLI_RESAMPLE_COLLECTION_H

#include "cli/class_options.h"
#include "common/outfile.h"
#include "resample/classes.h"
#include "resample/collection.h"
#include "resample/resample.h"

typedef struct wpd_cli_collection {
    wpd_collection c;
    wpd_night_request req;
    wpd_night night;
    int planned;              /* the night is planned (night valid) */
    int marked;               /* rank 0 wrote the night's mark */
} wpd_cli_collection;

/* The request from the options (strings owned by cc). Returns 0, or -1
 * with err set. */
int wpd_cli_collection_init(wpd_cli_collection *cc, const char *outdir, const char *output,
                            const wpd_params *p, const wpd_class_args *classes, double spacing,
                            int rebuild, int skip_existing, const wpd_par *par, wpd_error *err);

/* Rank 0, the collection's lock held, before the sweep of stale files:
 * completes or rolls back a night that did not finish (one line on stderr
 * unless quiet) and marks this one. Returns 0, or -1 with err set. */
int wpd_cli_collection_recover(wpd_cli_collection *cc, int quiet, wpd_error *err);

/* Every rank: plans the night (resample/collection.h); the new inputs are
 * then inputs[0 .. cc->night.nnew - 1]. Fails (WPD_E_USAGE) for an
 * --append output that exists without a state, unless overwrite.
 * Returns 0, or -1 with err set. */
int wpd_cli_collection_plan(wpd_cli_collection *cc, char **inputs, int ninputs, int overwrite,
                            wpd_error *err);

/* The run's options for the night: a later night's radius, factor and
 * fixed samples, or --spacing's radius. */
void wpd_cli_collection_options(const wpd_cli_collection *cc, wpd_resample_options *ro);

/* Rank 0, every output finished under its temporary name (files[0 ..
 * n-1]): with --append OUT's records and the night's made one file
 * (files[0] replaced), the state after the night recorded in cc->c.
 * Returns 0, or -1 with err set. */
int wpd_cli_collection_record(wpd_cli_collection *cc, const wpd_resample_result *res,
                              const wpd_class_result *classes, wpd_outfile *files, int n,
                              wpd_error *err);

/* The summary's lines of the night (stdout). target: the count -n asks of
 * the night's points (only compared with on a later night). */
void wpd_cli_collection_print(const wpd_cli_collection *cc, size_t written,
                              unsigned long long target, const char *count_text);

/* The report's "collection" object (docs/report.md). */
void wpd_cli_collection_report(const wpd_cli_collection *cc, FILE *f);

void wpd_cli_collection_free(wpd_cli_collection *cc);

#endif
