/* par_single.c - the one rank of a plain run (wpd without MPI): every
 * agreement is this rank's own result and every exchange is a copy. */
#include "par/par.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct wpd_par {
    int unused;
};

wpd_par *wpd_par_start(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    wpd_par *par = calloc(1, sizeof *par);
    if (!par) {
        fprintf(stderr, "wpd: out of memory\n");
        return NULL;
    }
    return par;
}

void wpd_par_end(wpd_par *par)
{
    free(par);
}

int wpd_par_rank(const wpd_par *par)
{
    (void)par;
    return 0;
}

int wpd_par_ranks(const wpd_par *par)
{
    (void)par;
    return 1;
}

int wpd_par_agree(const wpd_par *par, wpd_error *err)
{
    (void)par;
    return err->code == WPD_OK ? 0 : -1;
}

int wpd_par_close(const wpd_par *par, wpd_error *err)
{
    return wpd_par_agree(par, err);
}

int wpd_par_sum_u64(const wpd_par *par, uint64_t *v, size_t n, wpd_error *err)
{
    (void)par, (void)v, (void)n, (void)err;
    return 0;
}

int wpd_par_min_f64(const wpd_par *par, double *v, size_t n, wpd_error *err)
{
    (void)par, (void)v, (void)n, (void)err;
    return 0;
}

int wpd_par_max_f64(const wpd_par *par, double *v, size_t n, wpd_error *err)
{
    (void)par, (void)v, (void)n, (void)err;
    return 0;
}

int wpd_par_or_u8(const wpd_par *par, uint8_t *v, size_t n, wpd_error *err)
{
    (void)par, (void)v, (void)n, (void)err;
    return 0;
}

int wpd_par_gather_all(const wpd_par *par, const void *mine, size_t n, uint8_t **all,
                       size_t *off, size_t *len, wpd_error *err)
{
    (void)par;
    *all = malloc(n ? n : 1);
    if (!*all)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (n)
        memcpy(*all, mine, n);
    off[0] = 0;
    len[0] = n;
    return 0;
}

int wpd_par_gather_to(const wpd_par *par, int root, const void *mine, size_t n, uint8_t **all,
                      size_t *off, size_t *len, wpd_error *err)
{
    (void)root;
    return wpd_par_gather_all(par, mine, n, all, off, len, err);
}

uint64_t wpd_par_sent(const wpd_par *par)
{
    (void)par;
    return 0;
}
