/* par_mpi.c - the ranks of wpd-mpi: one MPI process per rank, on a
 * communicator of its own (a duplicate of MPI_COMM_WORLD) whose errors
 * return instead of aborting, so that a failed exchange is reported like
 * any other I/O error. Only the main thread calls MPI (MPI_THREAD_FUNNELED:
 * OpenMP threads never do). Built only by `make MPI=1`. */
#include "par/par.h"

#include <limits.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct wpd_par {
    MPI_Comm comm;
    int rank, ranks;
    uint64_t *sent;           /* payload handed to exchanges (a counter the const
                                 handle may add to) */
};

wpd_par *wpd_par_start(int *argc, char ***argv)
{
    int provided = 0;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "wpd: MPI could not start\n");
        return NULL;
    }
    if (provided < MPI_THREAD_FUNNELED) { /* OpenMP threads beside MPI need it */
        fprintf(stderr, "wpd: this MPI library cannot run beside threads "
                        "(MPI_THREAD_FUNNELED not provided)\n");
        MPI_Finalize();
        return NULL;
    }
    wpd_par *par = calloc(1, sizeof *par);
    if (par)
        par->sent = calloc(1, sizeof *par->sent);
    if (!par || !par->sent || MPI_Comm_dup(MPI_COMM_WORLD, &par->comm) != MPI_SUCCESS) {
        fprintf(stderr, "wpd: MPI could not start\n");
        if (par)
            free(par->sent);
        free(par);
        MPI_Finalize();
        return NULL;
    }
    MPI_Comm_set_errhandler(par->comm, MPI_ERRORS_RETURN);
    MPI_Comm_rank(par->comm, &par->rank);
    MPI_Comm_size(par->comm, &par->ranks);
    return par;
}

void wpd_par_end(wpd_par *par)
{
    if (!par)
        return;
    MPI_Comm_free(&par->comm);
    free(par->sent);
    free(par);
    MPI_Finalize();
}

int wpd_par_rank(const wpd_par *par)
{
    return par ? par->rank : 0;
}

int wpd_par_ranks(const wpd_par *par)
{
    return par ? par->ranks : 1;
}

static int mpi_failed(wpd_error *err, const char *what, int rc)
{
    char text[MPI_MAX_ERROR_STRING] = "";
    int len = 0;
    MPI_Error_string(rc, text, &len);
    return wpd_fail(err, WPD_E_IO, "MPI %s failed: %s", what, text);
}

/* A failure as it travels between ranks. */
typedef struct wire_error {
    int code;
    char msg[WPD_ERRMSG_MAX];
} wire_error;

/* One round of agreement: every rank gives whether it failed and whether it
 * is closing. Returns 1 when some rank failed (err: the lowest failing
 * rank's error), else 0; *all_closing and *any_closing say who closes. */
static int agree_round(const wpd_par *par, wpd_error *err, int closing, int *all_closing,
                       int *any_closing)
{
    int in[3] = {err->code != WPD_OK ? par->rank : par->ranks, closing, -closing}, out[3];
    int rc = MPI_Allreduce(in, out, 3, MPI_INT, MPI_MIN, par->comm);
    if (rc != MPI_SUCCESS) {
        mpi_failed(err, "agreement", rc);
        *all_closing = *any_closing = 1; /* the ranks cannot talk: stop */
        return 1;
    }
    *all_closing = out[1];
    *any_closing = -out[2];
    if (out[0] == par->ranks)
        return 0;
    wire_error w = {err->code, ""};
    memcpy(w.msg, err->msg, sizeof w.msg);
    rc = MPI_Bcast(&w, (int)sizeof w, MPI_BYTE, out[0], par->comm);
    if (rc != MPI_SUCCESS)
        return mpi_failed(err, "agreement", rc), 1;
    err->code = (wpd_errcode)w.code;
    memcpy(err->msg, w.msg, sizeof err->msg);
    err->msg[sizeof err->msg - 1] = '\0';
    return 1;
}

int wpd_par_agree(const wpd_par *par, wpd_error *err)
{
    int all, any;
    if (agree_round(par, err, 0, &all, &any))
        return -1;
    if (any)
        return wpd_fail(err, WPD_E_IO, "another rank of the run ended early");
    return 0;
}

int wpd_par_close(const wpd_par *par, wpd_error *err)
{
    int failed = 0, all = 0, any;
    while (!all)
        failed |= agree_round(par, err, 1, &all, &any);
    return failed ? -1 : 0;
}

static int reduce(const wpd_par *par, void *v, size_t n, MPI_Datatype type, MPI_Op op,
                  wpd_error *err)
{
    /* In slices that an int counts. */
    int tsize = 0;
    MPI_Type_size(type, &tsize);
    size_t size = (size_t)tsize;
    *par->sent += n * size;
    for (size_t at = 0; at < n;) {
        size_t k = n - at < (size_t)INT_MAX / 8 ? n - at : (size_t)INT_MAX / 8;
        int rc = MPI_Allreduce(MPI_IN_PLACE, (char *)v + at * size, (int)k, type, op,
                               par->comm);
        if (rc != MPI_SUCCESS)
            return mpi_failed(err, "reduction", rc);
        at += k;
    }
    return 0;
}

int wpd_par_sum_u64(const wpd_par *par, uint64_t *v, size_t n, wpd_error *err)
{
    return reduce(par, v, n, MPI_UINT64_T, MPI_SUM, err);
}

int wpd_par_min_f64(const wpd_par *par, double *v, size_t n, wpd_error *err)
{
    return reduce(par, v, n, MPI_DOUBLE, MPI_MIN, err);
}

int wpd_par_max_f64(const wpd_par *par, double *v, size_t n, wpd_error *err)
{
    return reduce(par, v, n, MPI_DOUBLE, MPI_MAX, err);
}

int wpd_par_or_u8(const wpd_par *par, uint8_t *v, size_t n, wpd_error *err)
{
    return reduce(par, v, n, MPI_UINT8_T, MPI_BOR, err);
}

/* Whether every rank is ok (a MIN over the ranks): 1, 0, or -1 when the
 * ranks cannot talk (err set). */
static int all_ok(const wpd_par *par, int ok, wpd_error *err)
{
    int all = 0;
    int rc = MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, par->comm);
    return rc == MPI_SUCCESS ? all : (mpi_failed(err, "agreement", rc), -1);
}

/* Bytes a round of a gather carries from all ranks together: counts and
 * displacements fit an int, and the round's buffer stays small. */
#define GATHER_ROUND ((size_t)1 << 28)

/* One round of a gather: every rank's bytes [at, at + counts[k]) to every
 * rank (root < 0) or to root. */
static int gather_round(const wpd_par *par, int root, const void *from, int mine, void *slice,
                        const int *counts, const int *displs, wpd_error *err)
{
    int mrc = root < 0 ? MPI_Allgatherv(from, mine, MPI_BYTE, slice, counts, displs, MPI_BYTE,
                                        par->comm)
                       : MPI_Gatherv(from, mine, MPI_BYTE, slice, counts, displs, MPI_BYTE,
                                     root, par->comm);
    return mrc == MPI_SUCCESS ? 0 : (mpi_failed(err, "gather", mrc), -1);
}

/* wpd_par_gather_all (root < 0) and wpd_par_gather_to (root >= 0). */
static int gather(const wpd_par *par, int root, const void *mine, size_t n, uint8_t **all,
                  size_t *off, size_t *len, wpd_error *err)
{
    size_t ranks = (size_t)par->ranks;
    int receives = root < 0 || root == par->rank;
    *all = NULL;
    unsigned long long me = n, *each = malloc(ranks * sizeof *each);
    int *counts = malloc(ranks * sizeof *counts), *displs = malloc(ranks * sizeof *displs);
    uint8_t *slice = NULL;
    int rc = -1, ok = each && counts && displs;
    /* Every rank learns whether all could go on before any data moves. */
    int all_go = all_ok(par, ok, err);
    if (all_go <= 0) {
        if (all_go == 0)
            wpd_fail(err, WPD_E_MEMORY, "out of memory for an exchange between ranks");
        goto done;
    }
    int mrc = MPI_Allgather(&me, 1, MPI_UNSIGNED_LONG_LONG, each, 1, MPI_UNSIGNED_LONG_LONG,
                            par->comm);
    if (mrc != MPI_SUCCESS) {
        mpi_failed(err, "gather", mrc);
        goto done;
    }
    size_t total = 0, longest = 0;
    for (size_t k = 0; k < ranks; k++) {
        off[k] = total;
        len[k] = (size_t)each[k];
        total += len[k];
        longest = len[k] > longest ? len[k] : longest;
    }
    size_t cut = GATHER_ROUND / ranks < longest ? GATHER_ROUND / ranks : longest;
    cut = cut ? cut : 1;
    if (receives) {
        *all = malloc(total ? total : 1);
        slice = malloc(ranks * cut);
    }
    all_go = all_ok(par, !receives || (*all && slice), err);
    if (all_go <= 0) {
        if (all_go == 0)
            wpd_fail(err, WPD_E_MEMORY, "out of memory for an exchange of %zu bytes between "
                     "ranks", total);
        goto done;
    }
    *par->sent += root < 0 ? (uint64_t)n * (uint64_t)(par->ranks - 1)
                           : root == par->rank ? 0 : (uint64_t)n;
    /* Round j carries bytes [j cut, (j + 1) cut) of every part. */
    for (size_t at = 0; at < longest; at += cut) {
        int pos = 0;
        for (size_t k = 0; k < ranks; k++) {
            size_t m = len[k] > at ? (len[k] - at < cut ? len[k] - at : cut) : 0;
            counts[k] = (int)m, displs[k] = pos;
            pos += (int)m;
        }
        size_t mine_now = n > at ? (n - at < cut ? n - at : cut) : 0;
        const void *from = mine_now ? (const uint8_t *)mine + at : (const void *)&me;
        if (gather_round(par, root, from, (int)mine_now, receives ? slice : NULL, counts,
                         displs, err))
            goto done;
        for (size_t k = 0; receives && k < ranks; k++)
            if (counts[k])
                memcpy(*all + off[k] + at, slice + displs[k], (size_t)counts[k]);
    }
    rc = 0;
done:
    if (rc) {
        free(*all);
        *all = NULL;
    }
    free(slice);
    free(each);
    free(counts);
    free(displs);
    return rc;
}

int wpd_par_gather_all(const wpd_par *par, const void *mine, size_t n, uint8_t **all,
                       size_t *off, size_t *len, wpd_error *err)
{
    return gather(par, -1, mine, n, all, off, len, err);
}

int wpd_par_gather_to(const wpd_par *par, int root, const void *mine, size_t n, uint8_t **all,
                      size_t *off, size_t *len, wpd_error *err)
{
    return gather(par, root, mine, n, all, off, len, err);
}

uint64_t wpd_par_sent(const wpd_par *par)
{
    return par ? *par->sent : 0;
}
