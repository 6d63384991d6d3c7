#include "common/progress.h"

#include <omp.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

void wpd_progress_init(wpd_progress *p, wpd_progress_mode mode)
{
    memset(p, 0, sizeof *p);
    int tty = isatty(STDERR_FILENO);
    p->live = mode != WPD_PROGRESS_QUIET && tty;
    p->lines = mode == WPD_PROGRESS_VERBOSE;
}

void wpd_progress_phase(wpd_progress *p, const char *phase, uint64_t total, const char *unit)
{
    if (!p)
        return;
    p->phase = phase;
    p->unit = unit;
    p->total = total;
    __atomic_store_n(&p->done, 0, __ATOMIC_RELAXED);
    p->start = omp_get_wtime();
    p->next_print = p->start + 0.2;
}

/* "12.3 M" style: the rate's magnitude in a few characters. */
static void human(char *out, size_t size, double v)
{
    if (v >= 1e9)
        snprintf(out, size, "%.1f G", v / 1e9);
    else if (v >= 1e6)
        snprintf(out, size, "%.1f M", v / 1e6);
    else if (v >= 1e3)
        snprintf(out, size, "%.1f k", v / 1e3);
    else
        snprintf(out, size, "%.0f", v);
}

static void print_line(const wpd_progress *p, uint64_t done, int final)
{
    double elapsed = omp_get_wtime() - p->start;
    char rate[32], count[32];
    human(rate, sizeof rate, elapsed > 0 ? done / elapsed : 0);
    human(count, sizeof count, (double)done);
    if (final) {
        fprintf(stderr, "%s%-8s %s %s in %.1f s (%s %s/s)%s\n", p->live ? "\r" : "", p->phase, count,
                p->unit, elapsed, rate, p->unit, p->live ? "          " : "");
    } else if (p->total) {
        double frac = (double)done / (double)p->total;
        double eta = frac > 0 ? elapsed * (1 - frac) / frac : 0;
        fprintf(stderr, "\r%-8s %5.1f%%  %s %s/s  ETA %.0f s   ", p->phase,
                100 * (frac > 1 ? 1 : frac), rate, p->unit, eta);
    } else {
        fprintf(stderr, "\r%-8s %s %s  %s %s/s   ", p->phase, count, p->unit, rate, p->unit);
    }
    fflush(stderr);
}

void wpd_progress_add(wpd_progress *p, uint64_t n)
{
    if (!p || (!p->live && !p->lines))
        return;
    uint64_t done = __atomic_add_fetch(&p->done, n, __ATOMIC_RELAXED);
    if (!p->live)
        return;
    double now = omp_get_wtime();
    if (now < p->next_print || __atomic_exchange_n(&p->printing, 1, __ATOMIC_ACQUIRE))
        return;
    p->next_print = now + 0.2;
    print_line(p, done, 0);
    __atomic_store_n(&p->printing, 0, __ATOMIC_RELEASE);
}

void wpd_progress_end(wpd_progress *p)
{
    if (!p || !p->phase || (!p->live && !p->lines))
        return;
    print_line(p, __atomic_load_n(&p->done, __ATOMIC_RELAXED), 1);
    p->phase = NULL;
}
