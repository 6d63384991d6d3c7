/* progress.h - per-phase progress on stderr: percentage, rate and ETA,
 * redrawn in place when stderr is a terminal; one line per finished phase
 * with --verbose otherwise; nothing with --quiet or when disabled.
 * Updates may come from any thread; printing is throttled to 5 a second
 * and done by whichever thread crosses the time mark. */
#ifndef WPD_PROGRESS_H
#define WPD_PROGRESS_H

#include <stdint.h>

typedef enum wpd_progress_mode {
    WPD_PROGRESS_AUTO = 0,    /* on when stderr is a terminal */
    WPD_PROGRESS_VERBOSE,     /* always: in place on a terminal, else a line per phase */
    WPD_PROGRESS_QUIET        /* never */
} wpd_progress_mode;

typedef struct wpd_progress {
    int live;                 /* redraw in place (terminal) */
    int lines;                /* print a line when a phase ends */
    const char *phase, *unit;
    uint64_t total;
    uint64_t done;            /* updated atomically */
    double start, next_print;
    int printing;             /* atomic flag: one printer at a time */
} wpd_progress;

/* Sets p up for mode. */
void wpd_progress_init(wpd_progress *p, wpd_progress_mode mode);

/* Starts a phase of total units (0: unknown). p may be NULL (no-op). */
void wpd_progress_phase(wpd_progress *p, const char *phase, uint64_t total, const char *unit);

/* Adds n done units; thread-safe. p may be NULL. */
void wpd_progress_add(wpd_progress *p, uint64_t n);

/* Ends the phase (prints its final line). p may be NULL. */
void wpd_progress_end(wpd_progress *p);

#endif
