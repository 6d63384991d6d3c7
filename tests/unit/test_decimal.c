/* test_decimal.c - the exact decimal parser (io/decimal.h), directly. */
#include "harness.h"

#include <locale.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "io/decimal.h"

static int exact(const char *s, double *out) { return wpd_decimal_exact(s, strlen(s), out); }

TEST(decimal_exact_fast_path)
{
    double v;
    CHECK(exact("0", &v) == 1 && v == 0.0 && !signbit(v));
    CHECK(exact("-0", &v) == 1 && v == 0.0 && signbit(v));
    CHECK(exact("1.5", &v) == 1 && v == 1.5);
    CHECK(exact("+2.25e1", &v) == 1 && v == 22.5);
    CHECK(exact(".5", &v) == 1 && v == 0.5);
    CHECK(exact("5.", &v) == 1 && v == 5.0);
    CHECK(exact("0.1", &v) == 1 && v == 0.1);
    CHECK(exact("123456789012345", &v) == 1 && v == 123456789012345.0);
    CHECK(exact("1e22", &v) == 1 && v == 1e22);
    CHECK(exact("1e-22", &v) == 1 && v == 1e-22);
    CHECK(exact("0e999", &v) == 1 && v == 0.0);
    CHECK(exact("0.000001", &v) == 1 && v == 1e-6);
    /* Left to the slow path: more precision, wide exponents, other syntax. */
    CHECK(exact("1234567890123456", &v) == 0);
    CHECK(exact("1e23", &v) == 0);
    CHECK(exact("nan", &v) == 0);
    CHECK(exact("inf", &v) == 0);
    CHECK(exact("0x10", &v) == 0);
    CHECK(exact("1e", &v) == 0);
    CHECK(exact("", &v) == 0);
    CHECK(exact("-", &v) == 0);
    CHECK(exact(".", &v) == 0);
    CHECK(exact("1.5x", &v) == 0);
    /* The length bounds the token: what follows is not read. */
    CHECK(wpd_decimal_exact("2.5junk", 3, &v) == 1 && v == 2.5);
}

TEST(decimal_double_matches_strtod)
{
    locale_t c = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    CHECK(c != (locale_t)0);
    if (!c)
        return;
    static const char *const ok[] = {
        "3.141592653589793238", "1e23", "-2.2250738585072014e-308", "4.9e-324",
        "1.7976931348623157e308", "0.30000000000000004", "12345678901234567890", "0x1p-2",
    };
    for (size_t i = 0; i < sizeof ok / sizeof *ok; i++) {
        double v = 0;
        CHECK_MSG(wpd_decimal_double(ok[i], strlen(ok[i]), c, &v) == 0, "%s", ok[i]);
        CHECK_MSG(v == strtod(ok[i], NULL), "%s", ok[i]);
    }
    double v;
    CHECK(wpd_decimal_double("nan", 3, c, &v) == 0 && isnan(v));
    CHECK(wpd_decimal_double("-inf", 4, c, &v) == 0 && isinf(v) && v < 0);
    CHECK(wpd_decimal_double("1,5", 3, c, &v) == -1);
    CHECK(wpd_decimal_double("abc", 3, c, &v) == -1);
    CHECK(wpd_decimal_double("", 0, c, &v) == -1);
    char longer[WPD_DECIMAL_TOKEN_MAX + 2];
    memset(longer, '1', sizeof longer);
    CHECK(wpd_decimal_double(longer, sizeof longer, c, &v) == -1);
    freelocale(c);
}

TEST(decimal_integer)
{
    int neg;
    uint64_t mag;
    CHECK(wpd_decimal_integer("18446744073709551615", 20, &neg, &mag) == 1 && !neg &&
          mag == UINT64_MAX);
    CHECK(wpd_decimal_integer("18446744073709551616", 20, &neg, &mag) == -1);
    CHECK(wpd_decimal_integer("-0", 2, &neg, &mag) == 1 && neg && mag == 0);
    CHECK(wpd_decimal_integer("+7", 2, &neg, &mag) == 1 && !neg && mag == 7);
    CHECK(wpd_decimal_integer("1.0", 3, &neg, &mag) == 0);
    CHECK(wpd_decimal_integer("-", 1, &neg, &mag) == 0);
    CHECK(wpd_decimal_integer("", 0, &neg, &mag) == 0);
}

/* Parses s into a field of type t; returns the parser's code. */
static int field(const char *s, wpd_type t, locale_t c, uint8_t out[8])
{
    memset(out, 0xee, 8);
    return wpd_decimal_field(s, strlen(s), t, c, out);
}

TEST(decimal_field_ranges_and_forms)
{
    locale_t c = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
    CHECK(c != (locale_t)0);
    if (!c)
        return;
    uint8_t f[8];
    CHECK(field("-128", WPD_I8, c, f) == 0 && (int8_t)f[0] == -128 && f[1] == 0xee);
    CHECK(field("-129", WPD_I8, c, f) == -2 && f[0] == 0xee);
    CHECK(field("255", WPD_U8, c, f) == 0 && f[0] == 255);
    CHECK(field("256", WPD_U8, c, f) == -2);
    CHECK(field("-1", WPD_U16, c, f) == -2);
    CHECK(field("-0", WPD_U16, c, f) == 0 && wpd_value_get_int(WPD_U16, f) == 0);
    CHECK(field("3.0", WPD_I32, c, f) == 0 && wpd_value_get_int(WPD_I32, f) == 3);
    CHECK(field("1e2", WPD_I32, c, f) == 0 && wpd_value_get_int(WPD_I32, f) == 100);
    CHECK(field("3.5", WPD_I32, c, f) == -1);
    CHECK(field("nan", WPD_I32, c, f) == -1);
    CHECK(field("x", WPD_I32, c, f) == -1);
    CHECK(field("-9223372036854775808", WPD_I64, c, f) == 0 &&
          wpd_value_get_int(WPD_I64, f) == INT64_MIN);
    CHECK(field("18446744073709551615", WPD_U64, c, f) == 0 &&
          (uint64_t)wpd_value_get_int(WPD_U64, f) == UINT64_MAX);
    CHECK(field("1e20", WPD_U64, c, f) == -2);
    float fl;
    CHECK(field("0.1", WPD_F32, c, f) == 0 && (memcpy(&fl, f, 4), fl == 0.1f) && f[4] == 0xee);
    double d;
    CHECK(field("-2.5e-3", WPD_F64, c, f) == 0 && (memcpy(&d, f, 8), d == -2.5e-3));
    CHECK(field("1.2.3", WPD_F64, c, f) == -1);
    freelocale(c);
}
