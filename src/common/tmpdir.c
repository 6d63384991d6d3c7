/* tmpdir.c - private temporary directories removed on every exit path
 * (see tmpdir.h).
 *
 * The registry below is wpd's one piece of process-wide mutable state. It
 * has to be global: a signal handler receives no argument through which a
 * per-object list could reach it. It is a fixed array (no allocation, so
 * the handler can walk it at any moment), slots are claimed and released
 * under a mutex by normal code, and a slot's path is complete before its
 * state is published, so the handler never sees half a path.
 *
 * Only flat directories are supported: the spill writes plain files.
 */
#include "common/tmpdir.h"

#include <ctype.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* A resampling run holds up to five directories at once (the input spill,
 * the sample store and its borders, the exact count's fields, the result's
 * runs), and a run by class one more per resampled group until its records
 * are written: 64 leaves room for 59 groups. */
#define MAX_DIRS 64
#define PATH_CAP 1024

enum { SLOT_FREE = 0, SLOT_CLAIMED = 1, SLOT_LIVE = 2 };

/* What a slot stands for. */
enum { KIND_DIR = 0, KIND_FILE = 1, KIND_OUTPUTS = 2 };

static struct {
    char path[PATH_CAP];
    char marker[80];             /* KIND_OUTPUTS: ".wpd-tmp-<host>-<pid>-" */
    pid_t owner;                 /* a forked child leaves its parent's alone */
    int kind;                    /* KIND_*: a directory with all it holds, a
                                    temporary output, or the temporary outputs
                                    of this process in a directory */
    volatile sig_atomic_t state; /* SLOT_*; the handler removes SLOT_LIVE */
} registry[MAX_DIRS];

static pthread_mutex_t registry_mu = PTHREAD_MUTEX_INITIALIZER;
static int hooks_installed;

/* wpd_tmpdir_hold_signals: while holds are taken, the handler only notes
 * the signal. Part of the same process-wide state (the handler reaches
 * it). */
static int holds;
static int held_signal;

static const int cleanup_signals[] = {SIGINT, SIGTERM, SIGHUP};

/* Unlinks every entry of the directory path, then removes it. Only
 * async-signal-safe calls (open, getdents64, unlinkat, close, rmdir): it
 * runs in the signal handler. A few passes: a thread may still be creating
 * a file while we list. */
static void empty_and_remove(const char *path)
{
    for (int pass = 0; pass < 64; pass++) {
        int fd = open(path, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (fd < 0)
            return;
        char buf[4096] __attribute__((aligned(8)));
        ssize_t got;
        while ((got = getdents64(fd, buf, sizeof buf)) > 0) {
            for (ssize_t off = 0; off < got;) {
                const struct dirent64 *d = (const struct dirent64 *)(buf + off);
                off += d->d_reclen;
                const char *nm = d->d_name;
                if (nm[0] == '.' && (nm[1] == '\0' || (nm[1] == '.' && nm[2] == '\0')))
                    continue;
                if (unlinkat(fd, nm, 0) && errno == EISDIR)
                    unlinkat(fd, nm, AT_REMOVEDIR);
            }
        }
        close(fd);
        if (rmdir(path) == 0 || errno == ENOENT)
            return;
    }
}

/* 1 if needle occurs in hay (async-signal-safe: no library call). */
static int contains(const char *hay, const char *needle)
{
    for (; *hay; hay++) {
        size_t i = 0;
        while (needle[i] && hay[i] == needle[i])
            i++;
        if (!needle[i])
            return 1;
    }
    return 0;
}

/* Unlinks the entries of dir whose name contains marker. Async-signal-safe,
 * like empty_and_remove. */
static void remove_marked(const char *dir, const char *marker)
{
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return;
    char buf[4096] __attribute__((aligned(8)));
    ssize_t got;
    while ((got = getdents64(fd, buf, sizeof buf)) > 0)
        for (ssize_t off = 0; off < got;) {
            const struct dirent64 *d = (const struct dirent64 *)(buf + off);
            off += d->d_reclen;
            if (contains(d->d_name, marker))
                unlinkat(fd, d->d_name, 0);
        }
    close(fd);
}

static int ours(int k)
{
    return registry[k].state == SLOT_LIVE && registry[k].owner == getpid();
}

static void remove_slot(int k)
{
    if (registry[k].kind == KIND_FILE)
        unlink(registry[k].path);
    else if (registry[k].kind == KIND_OUTPUTS)
        remove_marked(registry[k].path, registry[k].marker);
    else
        empty_and_remove(registry[k].path);
}

static void remove_live_dirs(void)
{
    for (int k = 0; k < MAX_DIRS; k++)
        if (ours(k))
            remove_slot(k);
}

/* SIGINT/SIGTERM/SIGHUP: remove the directories, then die of the signal
 * with its default action (the re-raised signal is delivered when the
 * handler returns and unblocks it). */
static void on_signal(int sig)
{
    int saved = errno;
    /* Noted before the holds are read, and the last release drops its
     * hold before it reads the note (both sequentially consistent): a
     * signal taken while the hold ends is acted on by one side or both,
     * never by neither. */
    __atomic_store_n(&held_signal, sig, __ATOMIC_SEQ_CST);
    if (__atomic_load_n(&holds, __ATOMIC_SEQ_CST)) {
        errno = saved;
        return;
    }
    remove_live_dirs();
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
    raise(sig);
    errno = saved;
}

static void at_exit_cleanup(void)
{
    pthread_mutex_lock(&registry_mu);
    for (int k = 0; k < MAX_DIRS; k++)
        if (ours(k)) {
            remove_slot(k);
            registry[k].state = SLOT_FREE;
        }
    pthread_mutex_unlock(&registry_mu);
}

/* Installs the handlers (not over a signal the process ignores, e.g.
 * SIGHUP under nohup) and the exit hook, once. Lock held. */
static void install_hooks_locked(void)
{
    if (hooks_installed)
        return;
    hooks_installed = 1;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    /* A held signal returns from the handler: the calls it interrupted
     * then go on rather than fail with EINTR. */
    sa.sa_flags = SA_RESTART;
    sigemptyset(&sa.sa_mask);
    for (size_t k = 0; k < sizeof cleanup_signals / sizeof *cleanup_signals; k++)
        sigaddset(&sa.sa_mask, cleanup_signals[k]);
    for (size_t k = 0; k < sizeof cleanup_signals / sizeof *cleanup_signals; k++) {
        struct sigaction old;
        if (sigaction(cleanup_signals[k], NULL, &old) == 0 && old.sa_handler != SIG_IGN)
            sigaction(cleanup_signals[k], &sa, NULL);
    }
    atexit(at_exit_cleanup);
}

/* Claims a free registry slot (installing the hooks on first use).
 * Returns its index, or -1 when all are taken. */
static int claim_slot(void)
{
    pthread_mutex_lock(&registry_mu);
    install_hooks_locked();
    int slot = -1;
    for (int k = 0; k < MAX_DIRS && slot < 0; k++)
        if (registry[k].state == SLOT_FREE)
            slot = k;
    if (slot >= 0)
        registry[slot].state = SLOT_CLAIMED;
    pthread_mutex_unlock(&registry_mu);
    return slot;
}

/* Fills a claimed slot and makes it live. The state is stored last, with
 * release order: the signal handler must never see half a path. */
static void publish_slot(int slot, const char *path, size_t len, int kind)
{
    memcpy(registry[slot].path, path, len + 1);
    registry[slot].owner = getpid();
    registry[slot].kind = kind;
    __atomic_store_n(&registry[slot].state, SLOT_LIVE, __ATOMIC_RELEASE);
}

void wpd_tmpdir_host(char *out, size_t size)
{
    char name[256] = "";
    if (gethostname(name, sizeof name - 1) != 0)
        name[0] = '\0';
    name[sizeof name - 1] = '\0';
    size_t n = 0;
    /* The short name, in letters, digits, '_' and '-' (a name with others,
     * or none, still gives a tag: they become '_'). */
    for (const char *c = name; *c && *c != '.' && n + 1 < size && n < WPD_HOST_TAG_MAX; c++)
        out[n++] = (isalnum((unsigned char)*c) || *c == '-') ? *c : '_';
    if (n == 0 && size > 5)
        memcpy(out, "host", 4), n = 4;
    out[n] = '\0';
}

int wpd_tmpdir_create(const char *base, const char *prefix, char *out, size_t outlen,
                      wpd_error *err)
{
    char path[PATH_CAP], host[WPD_HOST_TAG_MAX + 1];
    wpd_tmpdir_host(host, sizeof host);
    int len = snprintf(path, sizeof path, "%s/%s-%s-%ld-XXXXXX", base, prefix, host,
                       (long)getpid());
    if (len < 0 || (size_t)len >= sizeof path || (size_t)len >= outlen)
        return wpd_fail(err, WPD_E_IO, "%s: path too long for a temporary directory", base);
    int slot = claim_slot();
    if (slot < 0)
        return wpd_fail(err, WPD_E_IO, "%s: more than %d temporary directories at once", base,
                        MAX_DIRS);
    /* Signals held so that the directory cannot come into existence
     * unregistered because of a signal taken here. */
    wpd_tmpdir_hold_signals();
    int ok = mkdtemp(path) != NULL;
    int saved = errno;
    if (ok)
        publish_slot(slot, path, (size_t)len, KIND_DIR);
    wpd_tmpdir_release_signals();
    if (!ok) {
        __atomic_store_n(&registry[slot].state, SLOT_FREE, __ATOMIC_RELEASE);
        errno = saved;
        return wpd_fail_errno(err, "%s: cannot create a temporary directory", base);
    }
    memcpy(out, path, (size_t)len + 1);
    return 0;
}

void wpd_tmpdir_hold_signals(void)
{
    /* The handlers must be in place: without them a signal kills at once. */
    pthread_mutex_lock(&registry_mu);
    install_hooks_locked();
    pthread_mutex_unlock(&registry_mu);
    __atomic_add_fetch(&holds, 1, __ATOMIC_SEQ_CST);
}

void wpd_tmpdir_release_signals(void)
{
    if (__atomic_sub_fetch(&holds, 1, __ATOMIC_SEQ_CST))
        return;
    int sig = __atomic_load_n(&held_signal, __ATOMIC_SEQ_CST);
    if (sig)
        on_signal(sig);
}

void wpd_tmpdir_remove(const char *path)
{
    pthread_mutex_lock(&registry_mu);
    for (int k = 0; k < MAX_DIRS; k++)
        if (registry[k].state == SLOT_LIVE && registry[k].kind == KIND_DIR &&
            strcmp(registry[k].path, path) == 0) {
            /* Emptied before it is unregistered: a signal arriving meanwhile
             * still finds it and finishes the job. */
            empty_and_remove(registry[k].path);
            registry[k].state = SLOT_FREE;
            break;
        }
    pthread_mutex_unlock(&registry_mu);
}

/* The pid in name if it is "<prefix><host>-<pid>-XXXXXX" with this host's
 * tag (wpd_tmpdir_host), or "<prefix><pid>-XXXXXX" (the names of versions
 * before the host tag, taken as this host's), XXXXXX 6 alphanumerics as
 * mkstemp and mkdtemp make them; else 0: not such a name, or another
 * host's, whose pid means nothing here. Read from the right: a host tag
 * may hold '-'. */
static long stale_pid(const char *name, const char *prefix, const char *host)
{
    size_t pl = strlen(prefix), nl = strlen(name);
    if (strncmp(name, prefix, pl) != 0 || nl < pl + 8 || name[nl - 7] != '-')
        return 0;
    for (size_t k = nl - 6; k < nl; k++)
        if (!isalnum((unsigned char)name[k]))
            return 0;
    size_t end = nl - 7, start = end; /* the pid: name[start, end) */
    while (start > pl && end - start < 10 && isdigit((unsigned char)name[start - 1]))
        start--;
    if (start == end || (start > pl && name[start - 1] != '-'))
        return 0;
    if (start > pl) { /* a host tag: name[pl, start - 1) */
        size_t hl = start - 1 - pl;
        if (hl != strlen(host) || strncmp(name + pl, host, hl) != 0)
            return 0;
    }
    long pid = 0;
    for (size_t k = start; k < end; k++)
        pid = pid * 10 + (name[k] - '0');
    return pid > 0 ? pid : 0;
}

/* Removes one leftover; 1 if it is gone. A directory must be this user's:
 * a shared base (/tmp) may hold another user's run of the same name. */
static int remove_leftover(const char *path, int dirs)
{
    if (!dirs)
        return unlink(path) == 0;
    struct stat st;
    if (lstat(path, &st) || !S_ISDIR(st.st_mode) || st.st_uid != getuid())
        return 0;
    empty_and_remove(path);
    return lstat(path, &st) != 0;
}

int wpd_tmpdir_sweep_dead(const char *dir, const char *prefix, int dirs)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    int removed = 0;
    char host[WPD_HOST_TAG_MAX + 1];
    wpd_tmpdir_host(host, sizeof host);
    struct dirent *e;
    while ((e = readdir(d))) {
        long pid = stale_pid(e->d_name, prefix, host);
        if (!pid || pid == (long)getpid() || pid > INT32_MAX)
            continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue; /* running, or someone else's */
        char path[2 * PATH_CAP + 256];
        if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) < (int)sizeof path)
            removed += remove_leftover(path, dirs);
    }
    closedir(d);
    return removed;
}

int wpd_tmpdir_sweep_stale(const char *base, const char *prefix)
{
    char dashed[PATH_CAP];
    if (snprintf(dashed, sizeof dashed, "%s-", prefix) >= (int)sizeof dashed)
        return 0;
    return wpd_tmpdir_sweep_dead(base, dashed, 1);
}

int wpd_tmpdir_track_file(const char *path)
{
    size_t len = strlen(path);
    int slot = len < PATH_CAP ? claim_slot() : -1;
    if (slot < 0)
        return -1;
    publish_slot(slot, path, len, KIND_FILE);
    return 0;
}

/* Frees the live slot of that kind and path (a path may be tracked as a
 * file and as an output directory at once). */
static void untrack(int kind, const char *path)
{
    pthread_mutex_lock(&registry_mu);
    for (int k = 0; k < MAX_DIRS; k++)
        if (registry[k].state == SLOT_LIVE && registry[k].kind == kind &&
            strcmp(registry[k].path, path) == 0) {
            registry[k].state = SLOT_FREE;
            break;
        }
    pthread_mutex_unlock(&registry_mu);
}

void wpd_tmpdir_untrack_file(const char *path)
{
    untrack(KIND_FILE, path);
}

int wpd_tmpdir_track_outputs(const char *dir)
{
    size_t len = strlen(dir);
    int slot = len < PATH_CAP ? claim_slot() : -1;
    if (slot < 0)
        return -1;
    char host[WPD_HOST_TAG_MAX + 1];
    wpd_tmpdir_host(host, sizeof host);
    snprintf(registry[slot].marker, sizeof registry[slot].marker, ".wpd-tmp-%s-%ld-", host,
             (long)getpid());
    publish_slot(slot, dir, len, KIND_OUTPUTS);
    return 0;
}

void wpd_tmpdir_untrack_outputs(const char *dir)
{
    untrack(KIND_OUTPUTS, dir);
}
