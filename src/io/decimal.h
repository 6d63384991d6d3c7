/* decimal.h - exact parsing of decimal numbers in ASCII text, for the
 * ascii PLY reader (and any other text format).
 *
 * Contract, shared by every function here:
 *   - input is a token (p, len): not NUL-terminated, no surrounding blanks;
 *     the whole token must be the number, or it is refused;
 *   - results are exact: an integer is its value or an error, never a
 *     rounded double; a floating-point number is the double nearest to
 *     the decimal value (round half to even), whatever the locale of the
 *     process (loc is a C locale, newlocale(LC_NUMERIC_MASK, "C", 0));
 *   - nothing is allocated, nothing global is touched: thread-safe.
 */
#ifndef WPD_DECIMAL_H
#define WPD_DECIMAL_H

#include <locale.h>
#include <stddef.h>
#include <stdint.h>

#include "io/schema.h"

/* Longest token wpd_decimal_double accepts (the tokenizers of the readers
 * refuse longer ones first, so none is refused here for its length). */
#define WPD_DECIMAL_TOKEN_MAX 1024

/* The fast path only: [+-]digits[.digits][(e|E)[+-]digits] with at most 15
 * significant digits and a decimal exponent within +-22 after moving the
 * point (or a value of zero). Then the digits are an exact integer and one
 * multiplication or division by an exact power of ten rounds correctly
 * (Clinger). Returns 1 with *out set, 0 when the token needs the slow
 * path (other syntax such as nan/inf/hex, or more precision). */
int wpd_decimal_exact(const char *p, size_t len, double *out);

/* A whole token as a double: the fast path, else strtod_l in loc (nan,
 * inf, hex and long forms). Returns 0 with *out set, -1 if the token is
 * not a number (or is empty or longer than WPD_DECIMAL_TOKEN_MAX). */
int wpd_decimal_double(const char *p, size_t len, locale_t loc, double *out);

/* An optionally signed run of decimal digits. Returns 1 with *neg and
 * *mag set (magnitude and sign apart, so -0 and UINT64_MAX both fit), 0 if
 * the token is not a plain integer, -1 if the magnitude overflows 64 bits. */
int wpd_decimal_integer(const char *p, size_t len, int *neg, uint64_t *mag);

/* One token into a little-endian field of type t at dst (wpd_type_size(t)
 * bytes; dst is left alone on failure). Integer types take plain integers
 * exactly, and also forms such as "3.0" or "1e2" that are whole numbers;
 * float stores the double rounded to float. Returns 0, -1 if the token is
 * not a number (not a whole number for an integer type), -2 if it is out
 * of the type's range. */
int wpd_decimal_field(const char *p, size_t len, wpd_type t, locale_t loc, uint8_t *dst);

#endif
