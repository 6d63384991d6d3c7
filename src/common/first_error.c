/* first_error.c - the first failure among threads (see first_error.h).
 *
 * One compare-and-swap decides which report is kept; the winner copies its
 * message while state says "being written", then publishes it with release
 * order, so a reader that sees 2 sees the whole message. The losers return
 * at once: no lock, no waiting, and a report never overwrites another.
 */
#include "common/first_error.h"

#include <stdatomic.h>

void wpd_first_error_keep(wpd_first_error *fe, const wpd_error *err)
{
    int empty = 0;
    if (!atomic_compare_exchange_strong_explicit(&fe->state, &empty, 1, memory_order_acquire,
                                                 memory_order_relaxed))
        return;
    fe->err = *err;
    atomic_store_explicit(&fe->state, 2, memory_order_release);
}

int wpd_first_error_failed(const wpd_first_error *fe)
{
    /* Relaxed: early exits only need to notice, not to read the message. */
    return atomic_load_explicit(&fe->state, memory_order_relaxed) != 0;
}

int wpd_first_error_take(const wpd_first_error *fe, wpd_error *err)
{
    if (atomic_load_explicit(&fe->state, memory_order_acquire) == 0)
        return 0;
    if (err)
        *err = fe->err;
    return -1;
}
