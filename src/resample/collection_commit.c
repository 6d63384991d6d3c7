/* collection_commit.c - a night's commit and the recovery of a night that
 * did not finish (collection.h).
 *
 * The state file is the commit point. Before it: the night's outputs are
 * complete under temporary names (tracked: a signal removes them), and
 * the new state, naming the renames still to do, is written beside the
 * old one as "<state>.new" and flushed. The commit renames it over the
 * state; from then on the night must happen, so the temporaries are no
 * longer the signal handlers' to remove, and the signals are held back
 * (tmpdir.h: whichever thread takes them, where blocking them on this
 * thread would hand them to an OpenMP worker) until the renames are done,
 * the folder synced and the state written again without them. A run
 * killed outright leaves one of: nothing new (a dead night's temporaries,
 * which the next run sweeps), a "<state>.new" that was never committed
 * (rolled back: removed with the temporaries it names), or a state that
 * names renames still to do (completed: the renames whose temporary is
 * there are done). The mark "<state>.run", written when a night starts,
 * tells the next run that one died before its commit, so that it can say
 * so. */
#include "resample/collection.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/fullio.h"
#include "common/outfile.h"
#include "common/testhook.h"
#include "common/tmpdir.h"

static void side_path(const wpd_collection *c, const char *suffix, char *out, size_t size)
{
    snprintf(out, size, "%s%s", c->state, suffix);
}

static int sync_dir(const char *dir, wpd_error *err)
{
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return wpd_fail_errno(err, "%s: cannot open the folder to sync it", dir);
    int rc = fsync(fd) != 0 && errno != EINVAL ? -1 : 0;
    int saved = errno;
    close(fd);
    errno = saved;
    return rc ? wpd_fail_errno(err, "%s: cannot sync the folder", dir) : 0;
}

/* c's state (with its renames) into path, flushed to disk. */
static int write_state(const wpd_collection *c, const char *path, wpd_error *err)
{
    char *text = NULL;
    size_t len = 0;
    if (wpd_collection_format(c, &text, &len)) {
        free(text);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
    }
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    int rc = fd < 0 ? wpd_fail_errno(err, "%s: cannot create", path) : 0;
    if (rc == 0 && wpd_write_full(fd, text, len))
        rc = wpd_fail_errno(err, "%s: write failed", path);
    if (rc == 0 && fsync(fd) != 0 && errno != EINVAL)
        rc = wpd_fail_errno(err, "%s: cannot flush", path);
    if (fd >= 0 && close(fd) != 0 && rc == 0)
        rc = wpd_fail_errno(err, "%s: cannot close", path);
    free(text);
    return rc;
}

/* The state written anew through "<state>.new" (the folder synced). */
static int replace_state(const wpd_collection *c, wpd_error *err)
{
    char next[1500];
    side_path(c, ".new", next, sizeof next);
    if (write_state(c, next, err))
        return -1;
    if (rename(next, c->state) != 0)
        return wpd_fail_errno(err, "%s: cannot rename %s into place", c->state, next);
    return sync_dir(c->dir, err);
}

static void drop_pending(wpd_collection *c)
{
    for (int i = 0; i < c->npending; i++)
        free(c->pending[i].from), free(c->pending[i].to);
    c->npending = 0;
}

/* The renames of c's pending list whose temporary is there. */
static int do_renames(const wpd_collection *c, wpd_error *err)
{
    for (int i = 0; i < c->npending; i++) {
        char from[1400], to[1400];
        snprintf(from, sizeof from, "%s/%s", c->dir, c->pending[i].from);
        snprintf(to, sizeof to, "%s/%s", c->dir, c->pending[i].to);
        if (access(from, F_OK) == 0 && rename(from, to) != 0)
            return wpd_fail_errno(err, "%s: cannot rename %s into place (the night is "
                                  "committed: the next run completes it)", to, from);
    }
    return sync_dir(c->dir, err);
}

int wpd_collection_commit(wpd_collection *c, wpd_outfile *files, int n, wpd_outfile *report,
                          wpd_error *err)
{
    char next[1500];
    side_path(c, ".new", next, sizeof next);
    /* (1) the new state beside the old one: a signal removes it */
    wpd_tmpdir_hold_signals();
    wpd_tmpdir_track_file(next);
    wpd_tmpdir_release_signals();
    if (write_state(c, next, err)) {
        unlink(next);
        wpd_tmpdir_untrack_file(next);
        return -1;
    }
    wpd_test_stall("commit");
    /* (2) the commit: from here the night happens, signal or not */
    wpd_tmpdir_hold_signals();
    for (int i = 0; i < n; i++)
        if (files[i].temp_path[0])
            wpd_tmpdir_untrack_file(files[i].temp_path);
    wpd_tmpdir_untrack_outputs(c->dir);
    wpd_tmpdir_untrack_file(next);
    int rc = 0;
    if (rename(next, c->state) != 0) {
        rc = wpd_fail_errno(err, "%s: cannot rename %s into place", c->state, next);
        unlink(next);
        for (int i = 0; i < n; i++) /* tracked no more: removed here */
            wpd_outfile_abort(&files[i]);
    }
    for (int i = 0; rc == 0 && i < n; i++)
        files[i].temp_path[0] = '\0'; /* the state's now: no error path removes them */
    if (rc == 0 && sync_dir(c->dir, err))
        rc = -1;
    if (rc == 0) {
        wpd_test_stall("renames");
        /* (3) the renames, then the state without them */
        rc = do_renames(c, err);
        if (rc == 0) {
            drop_pending(c);
            rc = replace_state(c, err);
        }
        if (rc == 0 && report && report->temp_path[0])
            rc = wpd_outfile_rename(report, err);
    }
    wpd_tmpdir_release_signals();
    return rc;
}

/* ------------------------------------------------------------ recovery */

/* Removes the temporary outputs of dead runs of this host in c's folder
 * (outfile.h: wpd_outfile_sweep_stale, for each output they belong to). */
static void sweep_dead(const wpd_collection *c)
{
    DIR *d = opendir(c->dir);
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL) {
        const char *tmp = e->d_name[0] == '.' ? strstr(e->d_name, ".wpd-tmp-") : NULL;
        if (!tmp || tmp == e->d_name + 1)
            continue;
        char path[1400];
        snprintf(path, sizeof path, "%s/%.*s", c->dir, (int)(tmp - e->d_name - 1),
                 e->d_name + 1);
        wpd_outfile_sweep_stale(path);
    }
    if (d)
        closedir(d);
}

/* A "<state>.new" never committed: it and the temporaries it names go.
 * A rewrite without renames (cut short after the commit) goes silently.
 * Returns 1 when a night was rolled back. */
static int roll_back_next(const wpd_collection *c)
{
    char next[1500];
    side_path(c, ".new", next, sizeof next);
    if (access(next, F_OK) != 0)
        return 0;
    wpd_collection n = {0};
    wpd_error ignored = {0};
    snprintf(n.dir, sizeof n.dir, "%s", c->dir);
    snprintf(n.state, sizeof n.state, "%.1390s", next);
    int parsed = wpd_collection_load(&n, &ignored) == 0;
    int named = parsed && n.npending > 0;
    for (int i = 0; named && i < n.npending; i++) {
        char from[1400];
        snprintf(from, sizeof from, "%s/%s", c->dir, n.pending[i].from);
        unlink(from);
    }
    wpd_collection_free(&n);
    unlink(next);
    return named || !parsed; /* cut short while a night wrote it */
}

int wpd_collection_recover(wpd_collection *c, int *said, wpd_error *err)
{
    *said = 0;
    wpd_error unread = {0};
    /* A state that does not read is for the plan to report. */
    if (wpd_collection_load(c, &unread) == 0 && c->npending > 0) {
        if (do_renames(c, err))
            return -1;
        drop_pending(c);
        if (replace_state(c, err))
            return -1;
        *said = 1;
    }
    char next[1500], mark[1500];
    side_path(c, ".new", next, sizeof next);
    side_path(c, ".run", mark, sizeof mark);
    if (*said)
        unlink(next); /* the rewrite that was cut short */
    else if (roll_back_next(c))
        *said = 2;
    if (unlink(mark) == 0 && !*said)
        *said = 2;
    if (*said == 2)
        sweep_dead(c);
    wpd_collection_free(c);
    return 0;
}

int wpd_collection_mark(const wpd_collection *c, wpd_error *err)
{
    char mark[1500];
    side_path(c, ".run", mark, sizeof mark);
    wpd_tmpdir_hold_signals();
    int fd = open(mark, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd >= 0)
        wpd_tmpdir_track_file(mark);
    wpd_tmpdir_release_signals();
    if (fd < 0)
        return wpd_fail_errno(err, "%s: cannot create", mark);
    close(fd);
    return 0;
}

void wpd_collection_unmark(const wpd_collection *c)
{
    char mark[1500];
    side_path(c, ".run", mark, sizeof mark);
    unlink(mark);
    wpd_tmpdir_untrack_file(mark);
}

int wpd_collection_owns(const wpd_collection *c, const char *path)
{
    static const char *const sides[] = {"", ".new", ".run"};
    char file[1500];
    for (int k = 0; k < 3; k++) {
        side_path(c, sides[k], file, sizeof file);
        if (wpd_path_same_place(path, file))
            return 1;
    }
    for (int i = 0; i < c->noutputs; i++) {
        snprintf(file, sizeof file, "%s/%s", c->dir, c->outputs[i].name);
        if (wpd_path_same_place(path, file))
            return 1;
    }
    return 0;
}
