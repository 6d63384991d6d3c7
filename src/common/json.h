/* json.h - just enough JSON output for reports and `wpd info --json`. */
#ifndef WPD_JSON_H
#define WPD_JSON_H

#include <stdio.h>

/* Writes s as a JSON string literal (quotes, escapes, control characters
 * and invalid bytes as \u00XX). */
void wpd_json_string(FILE *f, const char *s);
/* Writes v as a JSON number with full double precision; non-finite values,
 * which JSON cannot hold, as null. */
void wpd_json_number(FILE *f, double v);

#endif
