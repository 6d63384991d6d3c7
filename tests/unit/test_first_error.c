/* test_first_error.c - wpd_first_error under many threads reporting at once. */
#include "harness.h"

#include <omp.h>
#include <string.h>

#include "common/first_error.h"

/* Thread t's report: code 100 + t, a full-length message of one letter, so
 * a mix of two reports would show as two letters. */
static void report_of(int t, wpd_error *e)
{
    e->code = (wpd_errcode)(100 + t);
    memset(e->msg, 'a' + t % 26, sizeof e->msg - 1);
    e->msg[sizeof e->msg - 1] = '\0';
}

/* 1 if e is exactly some thread's report (not torn). */
static int is_whole_report(const wpd_error *e, int nthreads)
{
    int t = (int)e->code - 100;
    if (t < 0 || t >= nthreads)
        return 0;
    wpd_error want;
    report_of(t, &want);
    return memcmp(e->msg, want.msg, sizeof want.msg) == 0;
}

TEST(first_error_empty)
{
    wpd_first_error fe = {0};
    wpd_error e = {.code = WPD_E_IO, .msg = "untouched"};
    CHECK(!wpd_first_error_failed(&fe));
    CHECK(wpd_first_error_take(&fe, &e) == 0);
    CHECK(e.code == WPD_E_IO && !strcmp(e.msg, "untouched"));
    CHECK(wpd_first_error_take(&fe, NULL) == 0);
}

TEST(first_error_keeps_the_first)
{
    wpd_first_error fe = {0};
    wpd_error a = {.code = WPD_E_INPUT, .msg = "first"};
    wpd_error b = {.code = WPD_E_IO, .msg = "second"};
    wpd_first_error_keep(&fe, &a);
    CHECK(wpd_first_error_failed(&fe));
    wpd_first_error_keep(&fe, &b);
    wpd_error got = {0};
    CHECK(wpd_first_error_take(&fe, &got) == -1);
    CHECK(got.code == WPD_E_INPUT && !strcmp(got.msg, "first"));
    CHECK(wpd_first_error_take(&fe, NULL) == -1);
}

/* Every thread reports at once (after a barrier), many rounds: one whole
 * report is kept each round; a report set before the threads start
 * survives them intact. */
TEST(first_error_many_threads)
{
    enum { THREADS = 32, ROUNDS = 200 };
    int torn = 0, missing = 0, overwritten = 0, seen_failed = 0, reports = 0;
    for (int round = 0; round < ROUNDS; round++) {
        wpd_first_error fe = {0}, preset = {0};
        wpd_error first = {.code = WPD_E_MEMORY, .msg = "set before the threads"};
        wpd_first_error_keep(&preset, &first);
#pragma omp parallel num_threads(THREADS) reduction(+ : seen_failed, reports)
        {
            wpd_error mine;
            report_of(omp_get_thread_num(), &mine);
#pragma omp barrier
            wpd_first_error_keep(&fe, &mine);
            wpd_first_error_keep(&preset, &mine);
            seen_failed += wpd_first_error_failed(&fe);
            reports++;
        }
        wpd_error got;
        memset(&got, 0, sizeof got);
        if (wpd_first_error_take(&fe, &got) != -1)
            missing++;
        else if (!is_whole_report(&got, THREADS))
            torn++;
        memset(&got, 0, sizeof got);
        if (wpd_first_error_take(&preset, &got) != -1 || got.code != WPD_E_MEMORY ||
            strcmp(got.msg, first.msg))
            overwritten++;
    }
    CHECK_MSG(missing == 0, "%d rounds kept nothing", missing);
    CHECK_MSG(torn == 0, "%d rounds kept a torn or unknown report", torn);
    CHECK_MSG(overwritten == 0, "%d rounds overwrote the first report", overwritten);
    /* Each thread reported before asking, so each saw a failure. */
    CHECK(reports >= ROUNDS && seen_failed == reports);
}
