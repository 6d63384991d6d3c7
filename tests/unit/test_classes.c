/* test_classes.c - the class options: list and count syntax, conflicts,
 * and the class of a record (LAS bit field, PLY integer property). */
#include "harness.h"

#include <stdlib.h>
#include <string.h>

#include "cli/class_options.h"
#include "io/cloud.h"

/* The classes set by parsing text into a fresh set, as a count; -1 on a
 * parse error. */
static long parsed(const char *text, uint8_t **set)
{
    wpd_error err = {0};
    free(*set);
    *set = NULL;
    if (wpd_class_list_parse(text, set, &err))
        return err.code == WPD_E_USAGE && strstr(err.msg, text) ? -1 : -2;
    long n = 0;
    for (long c = 0; c <= WPD_CLASS_MAX; c++)
        n += (*set)[c];
    return n;
}

TEST(class_lists_take_numbers_and_ranges)
{
    uint8_t *set = NULL;
    CHECK(parsed("2,6,9-12", &set) == 6);
    CHECK(set[2] && set[6] && set[9] && set[12] && !set[8] && !set[13] && !set[0]);
    CHECK(parsed("7", &set) == 1 && set[7]);
    CHECK(parsed("0-65535", &set) == 65536);
    CHECK(parsed("5-5,5", &set) == 1);
    const char *bad[] = {"", ",", "2,", ",2", "2,,3", "a", "2a", "-3", "3-", "5-2", "65536",
                         "1-70000", "1 ,2", "+2", "2.0", "1234567"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        CHECK_MSG(parsed(bad[i], &set) == -1, "'%s' accepted", bad[i]);
    free(set);
}

TEST(class_counts_want_class_equals_a_positive_count)
{
    wpd_class_args a = {0};
    wpd_error err = {0};
    CHECK(wpd_class_count_parse("2=1500", &a, &err) == 0);
    CHECK(wpd_class_count_parse("6=100k", &a, &err) == 0);
    CHECK(wpd_class_count_parse("9=2M", &a, &err) == 0);
    CHECK(a.ncounts == 3 && a.counts[0].cls == 2 && a.counts[0].count == 1500 &&
          a.counts[1].count == 100000 && a.counts[2].count == 2000000);
    const char *bad[] = {"2", "2=", "=5", "2=0", "2=-1", "2=1.5", "2=x", "x=2", "2=5%",
                         "70000=5", "2=5kk"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        CHECK_MSG(wpd_class_count_parse(bad[i], &a, &err) == -1 && err.code == WPD_E_USAGE,
                  "'%s' accepted", bad[i]);
    CHECK(a.ncounts == 3);
    CHECK(wpd_class_args_check(&a, &err) == 0);
    CHECK(wpd_class_count_parse("2=7", &a, &err) == 0);
    CHECK(wpd_class_args_check(&a, &err) == -1 && strstr(err.msg, "two counts"));
    wpd_class_args_free(&a);
}

TEST(class_conflicts_are_refused)
{
    wpd_class_args a = {0};
    wpd_error err = {0};
    CHECK(wpd_class_list_parse("7,18", &a.drop, &err) == 0);
    CHECK(wpd_class_list_parse("6", &a.keep, &err) == 0);
    CHECK(wpd_class_args_check(&a, &err) == 0 && wpd_class_args_used(&a));
    CHECK(wpd_class_count_parse("18=10", &a, &err) == 0);
    CHECK(wpd_class_args_check(&a, &err) == -1 && strstr(err.msg, "class 18"));
    wpd_class_args_free(&a);
    CHECK(wpd_class_list_parse("1-3", &a.drop, &err) == 0);
    CHECK(wpd_class_list_parse("3", &a.keep, &err) == 0);
    CHECK(wpd_class_args_check(&a, &err) == -1 && strstr(err.msg, "dropped and kept"));
    wpd_class_args_free(&a);
    CHECK(!wpd_class_args_used(&a));
}

TEST(class_of_a_record_reads_the_bits_and_refuses_non_classes)
{
    /* LAS formats 0-5: bits 0-4 of byte 15; the flags above are not the class. */
    wpd_dim las = {"classification", WPD_U8, 15, 0, 5, 0, 0, 0};
    uint8_t rec[32] = {0};
    rec[15] = 0xE0 | 6; /* synthetic, key point, withheld + building */
    CHECK(wpd_class_of(&las, rec) == 6);
    wpd_dim ply = {"label", WPD_I32, 4, 0, 0, 0, 0, 0};
    int32_t v = 70000;
    memcpy(rec + 4, &v, 4);
    CHECK(wpd_class_of(&ply, rec) == -1);
    v = -1;
    memcpy(rec + 4, &v, 4);
    CHECK(wpd_class_of(&ply, rec) == -1);
    v = 65535;
    memcpy(rec + 4, &v, 4);
    CHECK(wpd_class_of(&ply, rec) == 65535);
}
