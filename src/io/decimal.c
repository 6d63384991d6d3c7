/* decimal.c - exact parsing of decimal numbers in ASCII text (see
 * decimal.h): a fast path that is exact by construction, strtod_l (which
 * glibc rounds correctly) for the rest. */
#include "io/decimal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Exact powers of ten representable as doubles (Clinger's fast path). */
static const double exact_pow10[] = {
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
};

/* Appends the digits at *s to *mant (counted in *ndigits). Returns how many
 * were read, or -1 past 15 significant digits: then the mantissa may not
 * be exact in a double and the fast path does not apply. */
static int take_digits(const char **s, const char *end, uint64_t *mant, int *ndigits)
{
    int n = 0;
    for (; *s < end && (unsigned)(**s - '0') < 10; ++*s, n++) {
        if (*ndigits >= 15)
            return -1;
        *mant = *mant * 10 + (unsigned)(**s - '0');
        ++*ndigits;
    }
    return n;
}

/* Adds an exponent "(e|E)[+-]digits" at *s, if there is one, to *exp10.
 * Returns 0 when an 'e' has no digits. Magnitudes are capped at 10^4:
 * far beyond where the fast path gives up, without overflowing int. */
static int take_exponent(const char **s, const char *end, int *exp10)
{
    if (*s == end || (**s != 'e' && **s != 'E'))
        return 1;
    ++*s;
    int eneg = 0, e = 0, edigits = 0;
    if (*s < end && (**s == '-' || **s == '+'))
        eneg = *(*s)++ == '-';
    for (; *s < end && (unsigned)(**s - '0') < 10; ++*s, edigits++)
        if (e < 10000)
            e = e * 10 + (**s - '0');
    *exp10 += eneg ? -e : e;
    return edigits > 0;
}

/* At most 15 significant digits and |exponent| <= 22: the digits are an
 * exact integer and one multiplication or division by an exact power of
 * ten rounds correctly, so no strtod is needed for typical scan data. */
int wpd_decimal_exact(const char *p, size_t len, double *out)
{
    const char *s = p, *end = p + len;
    int neg = 0;
    if (s < end && (*s == '-' || *s == '+'))
        neg = *s++ == '-';
    uint64_t mant = 0;
    int ndigits = 0, exp10 = 0, any = 0;
    while (s < end && *s == '0') { /* leading zeros are not significant */
        s++;
        any = 1;
    }
    int n = take_digits(&s, end, &mant, &ndigits);
    if (n < 0)
        return 0;
    any |= n > 0;
    if (s < end && *s == '.') {
        s++;
        if (!ndigits) /* 0.000ddd: the zeros only move the point */
            for (; s < end && *s == '0'; s++, exp10--)
                any = 1;
        if ((n = take_digits(&s, end, &mant, &ndigits)) < 0)
            return 0;
        exp10 -= n;
        any |= n > 0;
    }
    if (!any || !take_exponent(&s, end, &exp10) || s != end)
        return 0;
    double v;
    if (mant == 0)
        v = 0.0;
    else if (exp10 < -22 || exp10 > 22)
        return 0;
    else
        v = exp10 < 0 ? (double)mant / exact_pow10[-exp10] : (double)mant * exact_pow10[exp10];
    *out = neg ? -v : v;
    return 1;
}

/* Parses a whole token as a double (nan, inf, hex and long forms via
 * strtod_l in the C locale). Returns 0, or -1 if the token is not a number. */
int wpd_decimal_double(const char *p, size_t len, locale_t loc, double *out)
{
    if (wpd_decimal_exact(p, len, out))
        return 0;
    char copy[WPD_DECIMAL_TOKEN_MAX + 1];
    if (len == 0 || len > WPD_DECIMAL_TOKEN_MAX)
        return -1;
    memcpy(copy, p, len);
    copy[len] = '\0';
    char *end;
    *out = strtod_l(copy, &end, loc);
    return end == copy + len ? 0 : -1;
}

/* Parses an optionally signed run of decimal digits exactly. Returns 1 with
 * *neg and *mag set, 0 if the token is not a plain integer, -1 if it
 * overflows 64 bits. */
int wpd_decimal_integer(const char *p, size_t len, int *neg, uint64_t *mag)
{
    const char *s = p, *end = p + len;
    *neg = 0;
    if (s < end && (*s == '-' || *s == '+'))
        *neg = *s++ == '-';
    if (s == end)
        return 0;
    uint64_t v = 0;
    for (; s < end; s++) {
        unsigned d = (unsigned)(*s - '0');
        if (d >= 10)
            return 0;
        if (__builtin_mul_overflow(v, 10, &v) || __builtin_add_overflow(v, d, &v))
            return -1;
    }
    *mag = v;
    return 1;
}

static const int64_t int_min[] = {
    [WPD_I8] = INT8_MIN, [WPD_U8] = 0, [WPD_I16] = INT16_MIN, [WPD_U16] = 0,
    [WPD_I32] = INT32_MIN, [WPD_U32] = 0, [WPD_I64] = INT64_MIN, [WPD_U64] = 0,
};
static const uint64_t int_max[] = {
    [WPD_I8] = INT8_MAX, [WPD_U8] = UINT8_MAX, [WPD_I16] = INT16_MAX,
    [WPD_U16] = UINT16_MAX, [WPD_I32] = INT32_MAX, [WPD_U32] = UINT32_MAX,
    [WPD_I64] = INT64_MAX, [WPD_U64] = UINT64_MAX,
};

/* Parses an ascii value for an integer property. Plain integers are exact;
 * a token such as "3.0" or "1e2" is accepted when it is a whole number.
 * Returns 0 with *bits set to the two's-complement value, -1 if the token
 * is not a whole number, -2 if it is out of the type's range. */
static int parse_int_value(const char *p, size_t len, wpd_type t, locale_t loc,
                           uint64_t *bits)
{
    int neg;
    uint64_t mag;
    int rc = wpd_decimal_integer(p, len, &neg, &mag);
    if (rc < 0)
        return -2;
    if (rc == 0) {
        double d;
        if (wpd_decimal_double(p, len, loc, &d) || !isfinite(d) || d != floor(d))
            return -1;
        if (d < (double)int_min[t] || d > (double)int_max[t] || fabs(d) >= 18446744073709551616.0)
            return -2;
        neg = d < 0;
        mag = (uint64_t)fabs(d);
    }
    if (neg) {
        if (mag == 0) {
            *bits = 0;
            return 0;
        }
        if (int_min[t] == 0 || mag - 1 > (uint64_t)(-(int_min[t] + 1)))
            return -2;
        *bits = (uint64_t)0 - mag;
    } else {
        if (mag > int_max[t])
            return -2;
        *bits = mag;
    }
    return 0;
}

/* Parses one ascii token into a little-endian field of type t at dst.
 * Returns 0, -1 (not a number) or -2 (out of range). */
int wpd_decimal_field(const char *p, size_t len, wpd_type t, locale_t loc, uint8_t *dst)
{
    if (t == WPD_F32 || t == WPD_F64) {
        double d;
        if (wpd_decimal_double(p, len, loc, &d))
            return -1;
        if (t == WPD_F64) {
            memcpy(dst, &d, 8);
        } else {
            float f = (float)d;
            memcpy(dst, &f, 4);
        }
        return 0;
    }
    uint64_t bits;
    int rc = parse_int_value(p, len, t, loc, &bits);
    if (rc)
        return rc;
    memcpy(dst, &bits, wpd_type_size(t)); /* low bytes first: little-endian host */
    return 0;
}
