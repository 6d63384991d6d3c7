/* run_ranks.h - what the ranks of an MPI run (par/par.h) settle between
 * them around one `wpd resample`: the memory budget they plan with, the
 * facts of the run for the report, and its outcome. With one rank (the
 * plain wpd) each is this process's own. */
#ifndef WPD_CLI_RUN_RANKS_H
#define WPD_CLI_RUN_RANKS_H

#include <stddef.h>

#include "cli/report.h"
#include "common/error.h"
#include "par/par.h"

/* The budget every rank plans with: the smallest of the ranks' (each may
 * have defaulted to its own machine's share). The tile plan, and so the
 * output, depends on it, so all must use one. Every rank calls it at the
 * same point, failed or not (err: this rank's failure, or WPD_OK).
 * Returns 0, or -1 with err set. */
int wpd_ranks_same_budget(const wpd_par *par, size_t *mem_bytes, wpd_error *err);

/* Before the outcome is agreed: the payload the ranks exchanged and the
 * largest peak memory of a rank into info (info->ranks: the ranks). rc:
 * this rank's result so far (-1 with err set). Returns 0, or -1 with err
 * set (some rank failed). */
int wpd_ranks_run_facts(const wpd_par *par, int rc, wpd_run_info *info, wpd_error *err);

/* The closing agreement on the run's outcome (wpd_par_close): 0 when
 * every rank succeeded, else -1 with the first failing rank's error. Every
 * rank passes here once, last; only then may rank 0 put the outputs in
 * place. A failure after it (rank 0 delivering the outputs) is rank 0's
 * alone. */
int wpd_ranks_outcome(const wpd_par *par, int rc, wpd_error *err);

#endif
