/* warnings.h - harmless oddities of an input file, kept for the command line
 * to print.
 *
 * Library code never prints (error.h). A reader that reads a file although it
 * bends its specification (a pointer past the end that nothing needs, bytes
 * after the points ...) records one line naming the file and what is odd,
 * "data.las: 12 bytes after the 10 point records belong to no record;
 * ignored", in the header it fills; the command prints each line once per
 * file on stderr as "wpd <command>: warning: <line>". The storage is fixed so
 * that a header holding the lines still copies as a plain value.
 */
#ifndef WPD_WARNINGS_H
#define WPD_WARNINGS_H

#include <stdint.h>
#include <stdio.h>

#include "common/error.h"

#define WPD_WARNINGS_MAX 8

typedef struct wpd_warnings {
    uint32_t n;                               /* lines stored */
    uint32_t unstored;                        /* further lines, only counted */
    char line[WPD_WARNINGS_MAX][WPD_ERRMSG_MAX];
} wpd_warnings;

/* Appends a printf-formatted line to w (control characters shown as '?',
 * like error messages). Past WPD_WARNINGS_MAX lines only counts it. */
void wpd_warn(wpd_warnings *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prints every line of w on f as "wpd <command>: warning: <line>", then one
 * line saying how many were not stored, if any. */
void wpd_warnings_print(FILE *f, const char *command, const wpd_warnings *w);

#endif
