/* test_outfile.c - outputs renamed together and standard output checked
 * (common/outfile.h). */
#include "harness.h"

#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/outfile.h"
#include "common/tmpdir.h"

/* Writes text into a new outfile for path, finished under its temporary
 * name. Returns 0 or -1. */
static int finished(wpd_outfile *f, const char *path, const char *text)
{
    wpd_error err = {0};
    if (wpd_outfile_open(f, path, 1, &err) || wpd_outfile_write(f, text, strlen(text), &err))
        return -1;
    return wpd_outfile_finish(f, &err);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

TEST(outfile_rename_all_puts_every_file_in_place_and_skips_cleared_ones)
{
    char paths[3][512];
    wpd_outfile files[4];
    wpd_outfile_clear_all(files, 4);
    for (int i = 0; i < 3; i++) {
        snprintf(paths[i], sizeof paths[i], "%s/together-%d.txt", test_tmp_dir(), i);
        unlink(paths[i]);
        CHECK(finished(&files[i], paths[i], "done\n") == 0);
        CHECK(!exists(paths[i])); /* under its temporary name until the rename */
    }
    wpd_error err = {0};
    CHECK(wpd_outfile_rename_all(files, 4, &err) == 0); /* files[3]: cleared, skipped */
    for (int i = 0; i < 3; i++) {
        CHECK(exists(paths[i]));
        CHECK(files[i].temp_path[0] == '\0');
        unlink(paths[i]);
    }
}

TEST(outfile_rename_all_removes_the_files_after_a_failed_rename)
{
    /* The second final name is a folder that is not empty: its rename
     * fails; the first stays in place, the second and third temporary
     * files are removed. */
    char dir[512], paths[3][600], blocker[700];
    snprintf(dir, sizeof dir, "%s/rename-fails", test_tmp_dir());
    mkdir(dir, 0700);
    for (int i = 0; i < 3; i++)
        snprintf(paths[i], sizeof paths[i], "%s/out-%d", dir, i);
    mkdir(paths[1], 0700);
    snprintf(blocker, sizeof blocker, "%s/keep", paths[1]);
    FILE *f = fopen(blocker, "w");
    CHECK(f != NULL);
    if (f)
        fclose(f);
    wpd_outfile files[3];
    wpd_outfile_clear_all(files, 3);
    for (int i = 0; i < 3; i++)
        CHECK(finished(&files[i], paths[i], "x") == 0);
    char temps[3][1100];
    for (int i = 0; i < 3; i++)
        snprintf(temps[i], sizeof temps[i], "%s", files[i].temp_path);
    wpd_error err = {0};
    CHECK(wpd_outfile_rename_all(files, 3, &err) == -1);
    CHECK_MSG(strstr(err.msg, paths[1]) == err.msg, "%s", err.msg);
    CHECK(exists(paths[0]));
    CHECK(!exists(paths[2]));
    for (int i = 1; i < 3; i++)
        CHECK_MSG(!exists(temps[i]), "%s left", temps[i]);
    unlink(paths[0]);
    unlink(blocker);
    rmdir(paths[1]);
    rmdir(dir);
}

TEST(outfile_stdout_flush_reports_lost_output)
{
    /* Standard output pointed at /dev/full for the test, then restored. */
    fflush(stdout);
    int saved = dup(STDOUT_FILENO);
    FILE *full = fopen("/dev/full", "w");
    CHECK(saved >= 0 && full != NULL);
    if (saved < 0 || !full)
        return;
    dup2(fileno(full), STDOUT_FILENO);
    fputs("lost\n", stdout);
    wpd_error err = {0};
    int rc = wpd_stdout_flush(&err);
    clearerr(stdout);
    dup2(saved, STDOUT_FILENO);
    close(saved);
    fclose(full);
    CHECK(rc == -1 && err.code == WPD_E_IO);
    CHECK_MSG(strstr(err.msg, "standard output: disk full") == err.msg, "%s", err.msg);
    CHECK(wpd_stdout_flush(&err) == 0);
}

static void *idle_thread(void *arg)
{
    (void)arg;
    for (;;)
        pause();
    return NULL;
}

/* In a child with a second thread that could take the signal: a SIGTERM
 * sent while the signals are held changes nothing (the temporary output
 * is still there, the child goes on); at the release the child removes it
 * and dies of the signal. */
TEST(tmpdir_held_signal_takes_effect_at_the_release)
{
    char path[512], marker[512];
    snprintf(path, sizeof path, "%s/held.txt", test_tmp_dir());
    snprintf(marker, sizeof marker, "%s/held-went-on", test_tmp_dir());
    unlink(marker);
    pid_t pid = fork();
    if (pid == 0) {
        wpd_outfile f;
        pthread_t t;
        if (finished(&f, path, "x") || pthread_create(&t, NULL, idle_thread, NULL))
            _exit(20);
        char temp[1100];
        snprintf(temp, sizeof temp, "%s", f.temp_path);
        wpd_tmpdir_hold_signals();
        kill(getpid(), SIGTERM);
        usleep(100 * 1000); /* delivered meanwhile, to either thread */
        if (!exists(temp))
            _exit(21);
        FILE *m = fopen(marker, "w");
        if (m)
            fclose(m);
        wpd_tmpdir_release_signals();
        _exit(22);
    }
    int status = 0;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
    CHECK_MSG(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM, "status %d", status);
    CHECK(exists(marker));
    CHECK(!exists(path));
    CHECK_MSG(wpd_outfile_sweep_stale(path) == 0, "a temporary output of %s was left", path);
    unlink(marker);
}
