/* main.c - runs every registered unit test; prints "N passed, N failed". */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include "harness.h"

#include <dirent.h>
#include <ftw.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static test_case *registry_head;
static char tmp_dir[256];

void test_register(test_case *t)
{
    t->next = registry_head;
    registry_head = t;
}

const char *test_data_dir(void)
{
    const char *dir = getenv("WPD_TEST_DATA");
    if (!dir)
        dir = "../shared/data";
    struct stat st;
    return stat(dir, &st) == 0 && S_ISDIR(st.st_mode) ? dir : NULL;
}

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st; (void)flag; (void)ftw;
    return remove(path);
}

static void remove_tmp_dir(void)
{
    if (tmp_dir[0])
        nftw(tmp_dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
}

const char *test_tmp_dir(void)
{
    if (!tmp_dir[0]) {
        const char *base = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
        snprintf(tmp_dir, sizeof tmp_dir, "%s/wpd-unit-XXXXXX", base);
        if (!mkdtemp(tmp_dir)) {
            perror("mkdtemp");
            exit(2);
        }
        atexit(remove_tmp_dir);
    }
    return tmp_dir;
}

int test_tmp_entries(const char *prefix, char *buf, size_t size)
{
    DIR *d = opendir(test_tmp_dir());
    int found = 0;
    for (struct dirent *e; d && (e = readdir(d));)
        if (!strncmp(e->d_name, prefix, strlen(prefix))) {
            snprintf(buf, size, "%s/%s", test_tmp_dir(), e->d_name);
            found++;
        }
    if (d)
        closedir(d);
    return found;
}

/* Registration order is reversed by the linked list; run in source order. */
static test_case *reverse(test_case *t)
{
    test_case *out = NULL;
    while (t) {
        test_case *next = t->next;
        t->next = out;
        out = t;
        t = next;
    }
    return out;
}

/* The signal tests check what a signal does to wpd, which leaves a signal
 * the process ignores ignored (nohup). A suite started in the background
 * by a non-interactive shell (SIGINT ignored) or under nohup (SIGHUP) would
 * hand that on to them: the default actions are restored first. */
static void restore_default_signal_actions(void)
{
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    for (size_t k = 0; k < sizeof sigs / sizeof *sigs; k++)
        signal(sigs[k], SIG_DFL);
}

int main(int argc, char **argv)
{
    const char *filter = argc > 1 ? argv[1] : NULL;
    restore_default_signal_actions();
    int passed = 0, failed = 0;
    for (test_case *t = reverse(registry_head); t; t = t->next) {
        if (filter && !strstr(t->name, filter))
            continue;
        int failures = 0;
        t->fn(&failures);
        if (failures) {
            printf("FAIL %s\n", t->name);
            failed++;
        } else {
            printf("ok   %s\n", t->name);
            passed++;
        }
        fflush(stdout);
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
