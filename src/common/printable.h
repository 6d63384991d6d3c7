/* printable.h - text from a file shown safely on a terminal. */
#ifndef WPD_PRINTABLE_H
#define WPD_PRINTABLE_H

#include <stddef.h>

/* Writes the C string src into dst (cap bytes, cap >= 1) with every byte
 * that is not printable ASCII as \xNN and a backslash as \\, so that a
 * terminal never receives control bytes from a file and the text stays
 * unambiguous. Stops before an escape that would not fit; always
 * terminates dst. Returns dst. */
char *wpd_printable(char *dst, size_t cap, const char *src);

/* Room wpd_printable needs for n source bytes (each at most 4, plus NUL). */
#define WPD_PRINTABLE_SIZE(n) (4 * (n) + 1)

#endif
