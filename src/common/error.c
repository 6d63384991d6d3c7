#include "common/error.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* Messages quote bytes from input files (VLR user ids, PLY header words,
 * ascii tokens): control characters there would break the one-line error
 * promise or drive the terminal, so they are shown as '?'. */
void wpd_one_line(char *msg)
{
    for (unsigned char *p = (unsigned char *)msg; *p; p++)
        if (*p < 0x20 || *p == 0x7f)
            *p = '?';
}

int wpd_fail(wpd_error *err, wpd_errcode code, const char *fmt, ...)
{
    if (!err)
        return -1;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
    wpd_one_line(err->msg);
    err->code = code;
    return -1;
}

int wpd_fail_errno(wpd_error *err, const char *fmt, ...)
{
    int saved = errno;
    if (!err)
        return -1;
    char what[WPD_ERRMSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    const char *why = (saved == ENOSPC || saved == EDQUOT || saved == EFBIG)
                          ? "disk full or file size limit reached"
                          : strerror(saved);
    snprintf(err->msg, sizeof err->msg, "%.300s: %s", what, why);
    wpd_one_line(err->msg);
    err->code = saved == ENOMEM ? WPD_E_MEMORY : WPD_E_IO;
    return -1;
}

void wpd_error_clear(wpd_error *err)
{
    if (!err)
        return;
    err->code = WPD_OK;
    err->msg[0] = '\0';
}
