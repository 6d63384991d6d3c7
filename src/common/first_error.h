/* first_error.h - the first failure among threads. A zero-initialised
 * wpd_first_error is empty; any thread may report a failure at any time;
 * only the first report is kept. Reading it back is for after the threads
 * have joined. */
#ifndef WPD_FIRST_ERROR_H
#define WPD_FIRST_ERROR_H

#include "common/error.h"

typedef struct wpd_first_error {
    _Atomic int state;       /* 0 empty, 1 being written, 2 holds err */
    wpd_error err;
} wpd_first_error;

/* Keeps *err if no failure was kept yet. Thread-safe, lock-free. err must
 * not be NULL. */
void wpd_first_error_keep(wpd_first_error *fe, const wpd_error *err);

/* Whether any failure was reported (any thread, any time): for early exits. */
int wpd_first_error_failed(const wpd_first_error *fe);

/* After the threads joined: returns 0 when nothing failed, else copies the
 * first failure to *err (err may be NULL) and returns -1. */
int wpd_first_error_take(const wpd_first_error *fe, wpd_error *err);

#endif
