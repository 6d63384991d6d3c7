/* run_ranks.c - the ranks' settlements around one resample run. */
#include "cli/run_ranks.h"

int wpd_ranks_same_budget(const wpd_par *par, size_t *mem_bytes, wpd_error *err)
{
    if (wpd_par_ranks(par) < 2)
        return err->code == WPD_OK ? 0 : -1;
    double m = (double)*mem_bytes; /* exact: budgets are far below 2^53 */
    if (wpd_par_agree(par, err) || wpd_par_min_f64(par, &m, 1, err))
        return -1;
    *mem_bytes = (size_t)m;
    return 0;
}

int wpd_ranks_run_facts(const wpd_par *par, int rc, wpd_run_info *info, wpd_error *err)
{
    info->ranks = wpd_par_ranks(par);
    if (info->ranks < 2)
        return rc;
    if (rc == 0)
        wpd_error_clear(err);
    else if (err->code == WPD_OK)
        err->code = WPD_E_IO;
    uint64_t sent = wpd_par_sent(par);
    double rss = (double)info->peak_rss_kb;
    if (wpd_par_agree(par, err) || wpd_par_sum_u64(par, &sent, 1, err) ||
        wpd_par_max_f64(par, &rss, 1, err))
        return -1;
    info->exchanged_bytes = sent;
    info->peak_rss_kb = (long)rss;
    return 0;
}

int wpd_ranks_outcome(const wpd_par *par, int rc, wpd_error *err)
{
    if (rc == 0)
        wpd_error_clear(err);
    else if (err->code == WPD_OK)
        err->code = WPD_E_IO; /* a failure must not read as success */
    return wpd_par_close(par, err);
}
