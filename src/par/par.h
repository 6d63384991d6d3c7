/* par.h - the ranks of a run: one process per rank under MPI (wpd-mpi,
 * par_mpi.c), one rank otherwise (wpd, par_single.c). The rest of wpd
 * knows ranks only through this interface; only par_mpi.c includes mpi.h.
 *
 * Agreement. A rank that fails must not leave the others waiting in an
 * exchange it will never join. So every exchange between ranks is preceded
 * by an agreement (wpd_par_agree) in which each rank says whether it
 * failed; when one did, every rank leaves the exchange with that failure
 * (the lowest failing rank's error: code and message) and goes to the
 * closing agreement (wpd_par_close), which every path of a run reaches
 * exactly once. The closing agreement repeats until every rank is in it,
 * so a rank that failed between two exchanges and went straight to its
 * closing agreement meets the others there, whichever exchange they were
 * at. Data exchanges (sums, gathers) only follow an agreement that
 * returned 0, which all ranks saw alike.
 *
 * Determinism: results of sums and gathers do not depend on the timing of
 * the ranks; gathers hand every rank the parts in rank order.
 */
#ifndef WPD_PAR_H
#define WPD_PAR_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_par wpd_par;

/* Starts the ranks (MPI_Init_thread under MPI, which must give at least
 * MPI_THREAD_FUNNELED: only the main thread ever calls MPI, never an
 * OpenMP worker; argc and argv may be changed by it). Returns the handle,
 * or NULL when MPI cannot start (message on stderr). */
wpd_par *wpd_par_start(int *argc, char ***argv);

/* Ends the ranks (MPI_Finalize) and frees par. NULL: nothing. */
void wpd_par_end(wpd_par *par);

/* This rank (0 .. ranks-1) and the number of ranks; a NULL par is the one
 * rank of a plain run. */
int wpd_par_rank(const wpd_par *par);
int wpd_par_ranks(const wpd_par *par);

/* Agreement before an exchange. err->code != WPD_OK: this rank failed
 * (err holds why). Returns 0 when no rank failed and none has closed;
 * otherwise -1 with err set to the lowest failing rank's error (a rank
 * already closing without an error gives WPD_E_IO "another rank of the run
 * ended early").
 * After -1 the caller goes to wpd_par_close. */
int wpd_par_agree(const wpd_par *par, wpd_error *err);

/* The closing agreement: every rank calls it once, last, with its own
 * result (err->code WPD_OK or its failure). Returns 0 when every rank
 * succeeded, or -1 with err set to the lowest failing rank's error. */
int wpd_par_close(const wpd_par *par, wpd_error *err);

/* Element-wise sums, minima or maxima over the ranks, in place; every rank
 * gets the result. Only after an agreement that returned 0. Returns 0 or
 * -1 (err: WPD_E_IO). */
int wpd_par_sum_u64(const wpd_par *par, uint64_t *v, size_t n, wpd_error *err);
int wpd_par_min_f64(const wpd_par *par, double *v, size_t n, wpd_error *err);
int wpd_par_max_f64(const wpd_par *par, double *v, size_t n, wpd_error *err);
/* Bitwise or of byte arrays. */
int wpd_par_or_u8(const wpd_par *par, uint8_t *v, size_t n, wpd_error *err);

/* Every rank's bytes (mine, n of them), to every rank: *all (malloc'd, the
 * caller frees it) holds the parts in rank order, part k at off[k] with
 * len[k] bytes (off, len: arrays of wpd_par_ranks() entries the caller
 * provides). Any size: the parts travel in slices that an int counts.
 * Only after an agreement that returned 0; a rank that cannot hold the
 * result makes every rank fail alike (the ranks agree before sending).
 * Returns 0 or -1 (err: WPD_E_MEMORY or WPD_E_IO, the same on every
 * rank). */
int wpd_par_gather_all(const wpd_par *par, const void *mine, size_t n, uint8_t **all,
                       size_t *off, size_t *len, wpd_error *err);

/* wpd_par_gather_all with one receiver: only rank root gets *all (the
 * others NULL); off and len are filled on every rank. Returns 0 or -1 as
 * wpd_par_gather_all. */
int wpd_par_gather_to(const wpd_par *par, int root, const void *mine, size_t n, uint8_t **all,
                      size_t *off, size_t *len, wpd_error *err);

/* Payload bytes this rank has handed to exchanges so far: a reduction's
 * array once, a gather's part once for every other rank. */
uint64_t wpd_par_sent(const wpd_par *par);

#endif
