/* first_error.c - see first_error.h. */
#include "common/first_error.h"

#include <stdatomic.h>

void wpd_first_error_keep(wpd_first_error *fe, const wpd_error *err)
{
    int empty = 0;
    if (!atomic_compare_exchange_strong(&fe->state, &empty, 1))
        return; /* a failure is kept already (or being written) */
    fe->err = *err;
    atomic_store(&fe->state, 2);
}

int wpd_first_error_failed(const wpd_first_error *fe)
{
    return atomic_load(&((wpd_first_error *)fe)->state) != 0;
}

int wpd_first_error_take(const wpd_first_error *fe, wpd_error *err)
{
    if (!wpd_first_error_failed(fe))
        return 0;
    if (err)
        *err = fe->err;
    return -1;
}
