#include "common/outfile.h"
#include "common/fullio.h"
#include "common/testhook.h"
#include "common/tmpdir.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* "<dir>/.<base>.wpd-tmp-<host>-<pid>-XXXXXX": hidden, in the output's
 * directory so the final rename never crosses file systems, and carrying the
 * host and pid so a later run on that host can tell a dead run's leftover
 * from a live one's (tmpdir.h). */
static int make_temp_name(wpd_outfile *f, const char *path)
{
    char dir_buf[1024], base_buf[1024], host[WPD_HOST_TAG_MAX + 1];
    snprintf(dir_buf, sizeof dir_buf, "%s", path);
    snprintf(base_buf, sizeof base_buf, "%s", path);
    wpd_tmpdir_host(host, sizeof host);
    int n = snprintf(f->temp_path, sizeof f->temp_path, "%s/.%s.wpd-tmp-%s-%ld-XXXXXX",
                     dirname(dir_buf), basename(base_buf), host, (long)getpid());
    return n > 0 && (size_t)n < sizeof f->temp_path ? 0 : -1;
}

/* Splits path into its directory and base name (copies in dir, base). */
static void split_path(const char *path, char *dir, char *base, size_t size)
{
    char a[1024], b[1024];
    snprintf(a, sizeof a, "%s", path);
    snprintf(b, sizeof b, "%s", path);
    snprintf(dir, size, "%s", dirname(a));
    snprintf(base, size, "%s", basename(b));
}

int wpd_outfile_sweep_stale(const char *path)
{
    char dir[1024], base[1024], prefix[1100];
    split_path(path, dir, base, sizeof dir);
    snprintf(prefix, sizeof prefix, ".%s.wpd-tmp-", base);
    return wpd_tmpdir_sweep_dead(dir, prefix, 0);
}

static void lock_path(const char *path, char *out, size_t size)
{
    char dir[1024], base[1024];
    split_path(path, dir, base, sizeof dir);
    snprintf(out, size, "%s/.%s.wpd-lock", dir, base);
}

int wpd_output_lock(const char *path, wpd_error *err)
{
    char lock[2200];
    lock_path(path, lock, sizeof lock);
    /* Between creating the file and registering it for removal, a signal
     * would leave it behind (the handlers remove only what is registered). */
    wpd_tmpdir_hold_signals();
    int fd = -1;
    /* The holder unlinks the lock file when done, so the file locked here
     * may already be unlinked by the time we hold it: then a third run can
     * create and lock a new one. Holding the lock counts only if the path
     * still names the locked file; otherwise try again on the new one. */
    for (int attempt = 0; attempt < 100; attempt++) {
        fd = open(lock, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0) {
            wpd_fail_errno(err, "%s: cannot create lock file %s", path, lock);
            wpd_tmpdir_release_signals();
            return -1;
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            close(fd);
            wpd_tmpdir_release_signals();
            return wpd_fail(err, WPD_E_IO, "%s: being written by another wpd run (lock %s)",
                            path, lock);
        }
        struct stat held, named;
        if (fstat(fd, &held) == 0 && stat(lock, &named) == 0 && held.st_dev == named.st_dev &&
            held.st_ino == named.st_ino)
            break;
        close(fd);
        fd = -1;
    }
    if (fd >= 0)
        wpd_tmpdir_track_file(lock); /* a signal must not leave it behind either */
    wpd_tmpdir_release_signals();
    if (fd < 0)
        return wpd_fail(err, WPD_E_IO, "%s: lock file %s keeps being replaced", path, lock);
    return fd;
}

void wpd_output_unlock(int fd, const char *path)
{
    if (fd < 0)
        return;
    char lock[2200];
    lock_path(path, lock, sizeof lock);
    unlink(lock);
    wpd_tmpdir_untrack_file(lock);
    close(fd);
}

int wpd_outfile_open(wpd_outfile *f, const char *path, int overwrite, wpd_error *err)
{
    wpd_outfile_sweep_stale(path);
    memset(f, 0, sizeof *f);
    f->fd = -1;
    if (strlen(path) >= sizeof f->final_path || make_temp_name(f, path)) {
        f->temp_path[0] = '\0'; /* abort must not unlink a cut name */
        return wpd_fail(err, WPD_E_USAGE, "%s: output path too long", path);
    }
    strcpy(f->final_path, path);
    struct stat st;
    if (!overwrite && stat(path, &st) == 0) {
        f->temp_path[0] = '\0';
        return wpd_fail(err, WPD_E_USAGE, "%s: output exists (use --force to replace it)", path);
    }
    /* Held from creating the file to registering it: a signal between
     * the two would leave it behind. */
    wpd_tmpdir_hold_signals();
    f->fd = mkostemp(f->temp_path, O_CLOEXEC);
    int saved = errno;
    if (f->fd >= 0)
        wpd_tmpdir_track_file(f->temp_path); /* removed if a signal stops the run */
    wpd_tmpdir_release_signals();
    if (f->fd < 0) {
        f->temp_path[0] = '\0';
        errno = saved;
        return wpd_fail_errno(err, "%s: cannot create output", path);
    }
    wpd_test_stall("write");
    /* mkostemp creates 0600; give the file the mode a plain creat() would. */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(f->fd, 0666 & ~mask);
    return 0;
}

/* Writes all len bytes at offset off, or at the current position when off
 * is negative. */
static int write_all(wpd_outfile *f, const void *buf, size_t len, long long off, wpd_error *err)
{
    int rc = off < 0 ? wpd_write_full(f->fd, buf, len)
                     : wpd_pwrite_full(f->fd, buf, len, (uint64_t)off);
    return rc ? wpd_fail_errno(err, "%s: write failed", f->final_path) : 0;
}

int wpd_outfile_write(wpd_outfile *f, const void *buf, size_t len, wpd_error *err)
{
    return write_all(f, buf, len, -1, err);
}

int wpd_outfile_pwrite(wpd_outfile *f, const void *buf, size_t len, long long off,
                       wpd_error *err)
{
    return write_all(f, buf, len, off < 0 ? 0 : off, err);
}

int wpd_outfile_place(const wpd_outfile *part, uint64_t len, const wpd_outfile *dest,
                      uint64_t off, wpd_error *err)
{
    int fd = open(dest->temp_path, O_WRONLY | O_CLOEXEC);
    if (fd < 0)
        return wpd_fail_errno(err, "%s: cannot open %s to write a part", dest->final_path,
                              dest->temp_path);
    enum { STEP = 1 << 20 };
    uint8_t *buf = malloc(STEP);
    int rc = buf ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (uint64_t at = 0; rc == 0 && at < len; at += STEP) {
        size_t n = len - at < STEP ? (size_t)(len - at) : STEP;
        ssize_t got = wpd_pread_full(part->fd, buf, n, at);
        if (got != (ssize_t)n)
            rc = got < 0 ? wpd_fail_errno(err, "%s: cannot read", part->temp_path)
                         : wpd_fail(err, WPD_E_IO, "%s: cut short", part->temp_path);
        else if (wpd_pwrite_full(fd, buf, n, off + at))
            rc = wpd_fail_errno(err, "%s: write failed", dest->final_path);
    }
    free(buf);
    /* The first process renames the output once every part is in: the
     * bytes must be on its storage by then (NFS reports lost writes at
     * close). */
    if (rc == 0 && fsync(fd) != 0 && errno != EINVAL)
        rc = wpd_fail_errno(err, "%s: cannot flush output", dest->final_path);
    if (close(fd) != 0 && rc == 0)
        rc = wpd_fail_errno(err, "%s: cannot close output", dest->final_path);
    return rc;
}

int wpd_outfile_finish(wpd_outfile *f, wpd_error *err)
{
    /* fsync before rename: after a crash the final name must never point at
     * a file whose data did not reach the disk. */
    if (fsync(f->fd) != 0 && errno != EINVAL) {
        wpd_fail_errno(err, "%s: cannot flush output", f->final_path);
        wpd_outfile_abort(f);
        return -1;
    }
    /* Storage that reports a failed write only at close (NFS, quotas). */
    if (close(f->fd) != 0) {
        f->fd = -1;
        wpd_fail_errno(err, "%s: cannot close output", f->final_path);
        wpd_outfile_abort(f);
        return -1;
    }
    f->fd = -1;
    return 0;
}

int wpd_outfile_rename(wpd_outfile *f, wpd_error *err)
{
    if (rename(f->temp_path, f->final_path) != 0) {
        wpd_fail_errno(err, "%s: cannot rename temporary output into place", f->final_path);
        wpd_outfile_abort(f);
        return -1;
    }
    wpd_tmpdir_untrack_file(f->temp_path);
    f->temp_path[0] = '\0';
    return 0;
}

int wpd_outfile_commit(wpd_outfile *f, wpd_error *err)
{
    return wpd_outfile_finish(f, err) ? -1 : wpd_outfile_rename(f, err);
}

void wpd_outfile_abort(wpd_outfile *f)
{
    if (f->fd >= 0)
        close(f->fd);
    f->fd = -1;
    if (f->temp_path[0]) {
        unlink(f->temp_path);
        wpd_tmpdir_untrack_file(f->temp_path);
    }
    f->temp_path[0] = '\0';
}

void wpd_outfile_clear_all(wpd_outfile *files, int n)
{
    for (int i = 0; i < n; i++) {
        files[i].fd = -1;
        files[i].temp_path[0] = '\0';
    }
}

int wpd_outfile_rename_all(wpd_outfile *files, int n, wpd_error *err)
{
    wpd_tmpdir_hold_signals();
    int rc = 0;
    for (int i = 0; i < n && rc == 0; i++)
        if (files[i].temp_path[0])
            rc = wpd_outfile_rename(&files[i], err);
    wpd_outfile_abort_all(files, n); /* no-op for the renamed ones */
    wpd_tmpdir_release_signals();
    return rc;
}

void wpd_outfile_abort_all(wpd_outfile *files, int n)
{
    for (int i = 0; i < n; i++)
        wpd_outfile_abort(&files[i]);
}

int wpd_stdout_flush(wpd_error *err)
{
    errno = 0;
    int flushed = fflush(stdout) == 0;
    if (flushed && !ferror(stdout))
        return 0;
    /* A write that failed earlier, while printing, left the error flag but
     * not its errno: then all that is known is that output was lost. */
    if (flushed || errno == 0)
        errno = EIO;
    return wpd_fail_errno(err, "standard output");
}

int wpd_path_is_one_of(const char *path, char *const *paths, int n)
{
    struct stat so, si;
    if (stat(path, &so) != 0)
        return 0;
    for (int i = 0; i < n; i++)
        if (stat(paths[i], &si) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
            return 1;
    return 0;
}

/* path's folder as a real path into dir (PATH_MAX), and its file name;
 * NULL when the folder does not resolve. */
static const char *folder_and_name(const char *path, char *dir)
{
    char copy[PATH_MAX];
    if (snprintf(copy, sizeof copy, "%s", path) >= (int)sizeof copy)
        return NULL;
    const char *slash = strrchr(path, '/');
    if (!realpath(dirname(copy), dir))
        return NULL;
    return slash ? slash + 1 : path;
}

int wpd_path_same_place(const char *a, const char *b)
{
    char *const other[1] = {(char *)b};
    if (!strcmp(a, b) || wpd_path_is_one_of(a, other, 1))
        return 1;
    char da[PATH_MAX], db[PATH_MAX];
    const char *na = folder_and_name(a, da), *nb = folder_and_name(b, db);
    return na && nb && *na && !strcmp(na, nb) && !strcmp(da, db);
}
