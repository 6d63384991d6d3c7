/* error.h - error reporting for every wpd module.
 *
 * Library code never prints: it fills a wpd_error and returns -1 (or NULL).
 * The command-line layer prints err.msg as the single line on stderr and
 * maps err.code to the process exit status. Messages name the file first:
 *   "data.las: header point count 1065 needs 36439 bytes but the file has 36405"
 */
#ifndef WPD_ERROR_H
#define WPD_ERROR_H

#include <stddef.h>

/* Categories double as documented exit codes. */
typedef enum wpd_errcode {
    WPD_OK = 0,
    WPD_E_USAGE = 1,  /* bad command line */
    WPD_E_INPUT = 2,  /* malformed or unsupported input file */
    WPD_E_IO = 3,     /* read/write failure, disk full, missing file */
    WPD_E_MEMORY = 4, /* allocation failed or budget too small */
    WPD_E_INTERRUPTED = 130
} wpd_errcode;

#define WPD_ERRMSG_MAX 512

typedef struct wpd_error {
    wpd_errcode code;
    char msg[WPD_ERRMSG_MAX];
} wpd_error;

/* Sets err (if not NULL) to code and a printf-formatted message; returns -1
 * so that callers can write `return wpd_fail(err, ...)`. Never fails. */
int wpd_fail(wpd_error *err, wpd_errcode code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Like wpd_fail with code WPD_E_IO, appending ": strerror(errno)". Disk-full
 * (ENOSPC, EDQUOT, EFBIG) is reported as such; ENOMEM gets WPD_E_MEMORY. */
int wpd_fail_errno(wpd_error *err, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Replaces every control character of msg (newlines included) by '?', so
 * that a message quoting bytes from a file stays one harmless line. */
void wpd_one_line(char *msg);

/* Clears err to WPD_OK and an empty message. */
void wpd_error_clear(wpd_error *err);

#endif
