/* harness.h - a minimal self-registering unit-test harness.
 *
 *   TEST(name) { CHECK(x == 1); CHECK_MSG(y > 0, "y=%d", y); }
 *
 * Tests register themselves through constructors; tests/unit/main.c runs
 * them all (or those whose name contains argv[1]) and prints the closing
 * line "N passed, N failed". A test fails when any CHECK in it fails.
 */
#ifndef WPD_TEST_HARNESS_H
#define WPD_TEST_HARNESS_H

#include <stdio.h>

typedef struct test_case {
    const char *name;
    void (*fn)(int *failures);
    struct test_case *next;
} test_case;

/* Adds a test to the registry (called from constructors only). */
void test_register(test_case *t);
/* Root directory of the shared real-file test data ("../shared/data" unless
 * WPD_TEST_DATA is set); NULL if it does not exist. */
const char *test_data_dir(void);
/* A fresh private temporary directory for this test run (created once,
 * removed at exit). */
const char *test_tmp_dir(void);
/* How many entries of test_tmp_dir() start with prefix; the path of the
 * last one found into buf (size bytes). */
int test_tmp_entries(const char *prefix, char *buf, size_t size);

#define TEST(name)                                                        \
    static void test_fn_##name(int *failures_);                           \
    static test_case test_case_##name = {#name, test_fn_##name, NULL};    \
    __attribute__((constructor)) static void test_reg_##name(void)        \
    {                                                                     \
        test_register(&test_case_##name);                                 \
    }                                                                     \
    static void test_fn_##name(int *failures_)

#define CHECK_MSG(cond, ...)                                              \
    do {                                                                  \
        if (!(cond)) {                                                    \
            fprintf(stderr, "  %s:%d: CHECK(%s) failed: ", __FILE__,      \
                    __LINE__, #cond);                                     \
            fprintf(stderr, __VA_ARGS__);                                 \
            fputc('\n', stderr);                                          \
            ++*failures_;                                                 \
        }                                                                 \
    } while (0)

#define CHECK(cond) CHECK_MSG(cond, "%s", "")

#endif
