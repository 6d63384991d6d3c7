/* fault.c - an LD_PRELOAD interposer that makes system and allocation calls
 * fail on demand, for the fault-injection tests (tests/e2e/test_faults.py
 * compiles it with `cc -shared -fPIC` into the test's directory).
 *
 * Every fault is off unless its environment variable is set:
 *
 *   WPD_FAULT_READ_FILE=PATH  WPD_FAULT_READ_AFTER=N
 *       read/pread/readv/preadv of PATH (any descriptor on the same inode)
 *       deliver N bytes in total, counted over every descriptor and pass;
 *       the read that would go past N fails with EIO, and every read
 *       after it: a disk that goes bad under a file being read.
 *       With WPD_FAULT_READ_EOF=1 they return end of file instead: a file
 *       that shrinks while it is read (truncated by another program).
 *       WPD_FAULT_READ_COUNT=FILE writes at exit the bytes read from PATH
 *       (without WPD_FAULT_READ_AFTER nothing fails): faults can then be
 *       placed at fractions of what a run reads, whatever its passes.
 *   WPD_FAULT_WRITE_DIR=DIR  WPD_FAULT_WRITE_AFTER=N
 *       write/pwrite/writev to files directly or indirectly under DIR
 *       accept N bytes in total, then fail with ENOSPC: a full disk.
 *   WPD_FAULT_SYNC_DIR=DIR
 *       fsync and fdatasync of files under DIR fail with EIO: the data
 *       written did not reach the disk.
 *   WPD_FAULT_CLOSE_DIR=DIR  [WPD_FAULT_CLOSE_AFTER=N]
 *       close of regular files under DIR reports ENOSPC (after really
 *       closing): storage that reports a full disk only at the end (NFS,
 *       quotas). With N, the first N such closes succeed (counted over
 *       every thread), the later ones fail. WPD_FAULT_CLOSE_COUNT=FILE
 *       writes at exit how many such closes there were (without
 *       WPD_FAULT_CLOSE_DIR nothing is counted): faults can then be placed
 *       at fractions of a run's closes (spill files opened and closed over
 *       and over).
 *   WPD_FAULT_MALLOC_FAIL=N  [WPD_FAULT_MALLOC_ALWAYS=1]
 *       the N-th allocation call (malloc, calloc, realloc, posix_memalign,
 *       aligned_alloc, memalign, valloc; counted from this library's
 *       constructor) returns NULL with ENOMEM; with ALWAYS every later one
 *       too. Threads share the count, so N lands in a phase, not on an
 *       exact call site.
 *   WPD_FAULT_MALLOC_ABOVE=BYTES
 *       every allocation of at least BYTES fails.
 *   WPD_FAULT_MALLOC_COUNT=FILE
 *       at exit, writes the number of allocation calls counted to FILE (to
 *       spread WPD_FAULT_MALLOC_FAIL over a whole run).
 *
 * The replacements call the kernel with syscall(2) and glibc's exported
 * __libc_* allocator entry points, so nothing here needs dlsym (which may
 * itself allocate) and nothing recurses.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <unistd.h>

extern void *__libc_malloc(size_t);
extern void *__libc_calloc(size_t, size_t);
extern void *__libc_realloc(void *, size_t);
extern void *__libc_memalign(size_t, size_t);

/* ------------------------------------------------------------ configuration */

static int read_on;                 /* WPD_FAULT_READ_FILE set */
static dev_t read_dev;
static ino_t read_ino;
static unsigned long long read_after;
static int read_eof;                /* 0 bytes instead of EIO past the limit */
static unsigned long long read_done; /* bytes delivered so far (atomic) */
static unsigned long long read_taken; /* bytes reads were allowed (atomic): the
                                         limit is checked against it, so two
                                         threads cannot both slip past it */

static char write_dir[4096];         /* canonical, with a trailing '/' */
static size_t write_dir_len;
static unsigned long long write_after;
static unsigned long long write_done;

static char sync_dir[4096];
static size_t sync_dir_len;
static char close_dir[4096];
static size_t close_dir_len;
static unsigned long long close_after;   /* closes that still succeed */
static unsigned long long close_done;    /* closes under close_dir so far */
static char close_count_file[4096];

static int malloc_on;                /* counting has started */
static unsigned long long malloc_fail;   /* 1-based call to fail, 0: none */
static int malloc_always;
static unsigned long long malloc_above;  /* 0: no size limit */
static unsigned long long malloc_calls;
static char malloc_count_file[4096];
static char read_count_file[4096];

static unsigned long long env_u64(const char *name, unsigned long long dflt)
{
    const char *v = getenv(name);
    return v && *v ? strtoull(v, NULL, 10) : dflt;
}

/* dir made canonical with a trailing slash into out; its length, 0 if the
 * variable is unset or the directory does not exist. */
static size_t canonical_dir(const char *name, char *out, size_t size)
{
    const char *v = getenv(name);
    char buf[PATH_MAX];
    if (!v || !*v || !realpath(v, buf) || strlen(buf) + 2 > size)
        return 0;
    snprintf(out, size, "%s/", buf);
    return strlen(out);
}

__attribute__((constructor)) static void fault_init(void)
{
    /* Allocation settings first: realpath below may allocate. */
    malloc_fail = env_u64("WPD_FAULT_MALLOC_FAIL", 0);
    malloc_always = env_u64("WPD_FAULT_MALLOC_ALWAYS", 0) != 0;
    malloc_above = env_u64("WPD_FAULT_MALLOC_ABOVE", 0);
    const char *cf = getenv("WPD_FAULT_MALLOC_COUNT");
    if (cf)
        snprintf(malloc_count_file, sizeof malloc_count_file, "%s", cf);
    const char *rc = getenv("WPD_FAULT_READ_COUNT");
    if (rc)
        snprintf(read_count_file, sizeof read_count_file, "%s", rc);
    const char *cc = getenv("WPD_FAULT_CLOSE_COUNT");
    if (cc)
        snprintf(close_count_file, sizeof close_count_file, "%s", cc);
    __atomic_store_n(&malloc_on, 1, __ATOMIC_RELEASE);

    const char *rf = getenv("WPD_FAULT_READ_FILE");
    struct stat st;
    if (rf && *rf && stat(rf, &st) == 0) {
        read_dev = st.st_dev;
        read_ino = st.st_ino;
        read_after = env_u64("WPD_FAULT_READ_AFTER", ~0ULL);
        read_eof = env_u64("WPD_FAULT_READ_EOF", 0) != 0;
        read_on = 1;
    }
    write_dir_len = canonical_dir("WPD_FAULT_WRITE_DIR", write_dir, sizeof write_dir);
    write_after = env_u64("WPD_FAULT_WRITE_AFTER", 0);
    sync_dir_len = canonical_dir("WPD_FAULT_SYNC_DIR", sync_dir, sizeof sync_dir);
    close_dir_len = canonical_dir("WPD_FAULT_CLOSE_DIR", close_dir, sizeof close_dir);
    close_after = env_u64("WPD_FAULT_CLOSE_AFTER", 0);
}

/* Writes value as a decimal line to path (at exit: raw system calls). */
static void write_count(const char *path, unsigned long long value)
{
    char line[32];
    int n = snprintf(line, sizeof line, "%llu\n", value);
    int fd = (int)syscall(SYS_openat, AT_FDCWD, path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC,
                          0644);
    if (fd >= 0) {
        if (syscall(SYS_write, fd, line, (size_t)n) < 0) { /* nothing to do about it */ }
        syscall(SYS_close, fd);
    }
}

__attribute__((destructor)) static void fault_fini(void)
{
    if (malloc_count_file[0])
        write_count(malloc_count_file, __atomic_load_n(&malloc_calls, __ATOMIC_RELAXED));
    if (read_count_file[0])
        write_count(read_count_file, __atomic_load_n(&read_done, __ATOMIC_RELAXED));
    if (close_count_file[0])
        write_count(close_count_file, __atomic_load_n(&close_done, __ATOMIC_RELAXED));
}

/* ------------------------------------------------------------ reads */

static int is_read_target(int fd)
{
    struct stat st;
    return read_on && fstat(fd, &st) == 0 && st.st_dev == read_dev && st.st_ino == read_ino;
}

/* How many of len bytes a read of the target may deliver: len, fewer (a
 * short read ending exactly at the limit: the file ends there) or 0 (the
 * read fails). With EIO the read that reaches past the limit fails as a
 * whole, as a bad block in its range would: a short read there could hand
 * a reader reading ahead everything it needs, and the fault would never
 * show (the engine's records pass stops reading at its last sample). */
static size_t read_allowance(size_t len)
{
    unsigned long long taken = __atomic_load_n(&read_taken, __ATOMIC_RELAXED);
    for (;;) {
        if (taken >= read_after)
            return 0;
        size_t allow = read_after - taken >= len ? len
                       : read_eof                ? (size_t)(read_after - taken)
                                                 : 0;
        if (!allow)
            return 0;
        if (__atomic_compare_exchange_n(&read_taken, &taken, taken + allow, 0, __ATOMIC_RELAXED,
                                        __ATOMIC_RELAXED))
            return allow;
    }
}

static ssize_t account_read(ssize_t got)
{
    if (got > 0)
        __atomic_add_fetch(&read_done, (unsigned long long)got, __ATOMIC_RELAXED);
    return got;
}

/* A read that was allowed `allow` bytes and delivered got: the part not
 * delivered (end of file, error) is handed back, so the limit counts
 * delivered bytes, as WPD_FAULT_READ_COUNT measures them. */
static ssize_t account_allowed(size_t allow, ssize_t got)
{
    size_t used = got > 0 ? (size_t)got : 0;
    if (used < allow)
        __atomic_sub_fetch(&read_taken, (unsigned long long)(allow - used), __ATOMIC_RELAXED);
    return account_read(got);
}

ssize_t read(int fd, void *buf, size_t len)
{
    if (len && is_read_target(fd)) {
        size_t allow = read_allowance(len);
        if (!allow)
            return read_eof ? 0 : (errno = EIO, -1);
        return account_allowed(allow, syscall(SYS_read, fd, buf, allow));
    }
    return syscall(SYS_read, fd, buf, len);
}

ssize_t pread(int fd, void *buf, size_t len, off_t off)
{
    if (len && is_read_target(fd)) {
        size_t allow = read_allowance(len);
        if (!allow)
            return read_eof ? 0 : (errno = EIO, -1);
        return account_allowed(allow, syscall(SYS_pread64, fd, buf, allow, off));
    }
    return syscall(SYS_pread64, fd, buf, len, off);
}

ssize_t pread64(int fd, void *buf, size_t len, off_t off) { return pread(fd, buf, len, off); }

/* A vector read, allowed 1 byte when it was checked: its real size. */
static ssize_t account_vector(ssize_t got)
{
    if (got > 1)
        __atomic_add_fetch(&read_taken, (unsigned long long)got - 1, __ATOMIC_RELAXED);
    else if (got < 1)
        __atomic_sub_fetch(&read_taken, 1ULL, __ATOMIC_RELAXED);
    return account_read(got);
}

/* The vector forms fail outright once the limit is reached and pass
 * through before it (wpd does not use them; they are here so that a
 * future use cannot slip past the fault). */
ssize_t readv(int fd, const struct iovec *iov, int n)
{
    if (!is_read_target(fd))
        return syscall(SYS_readv, fd, iov, n);
    if (!read_allowance(1))
        return read_eof ? 0 : (errno = EIO, -1);
    return account_vector(syscall(SYS_readv, fd, iov, n));
}

ssize_t preadv(int fd, const struct iovec *iov, int n, off_t off)
{
    if (!is_read_target(fd))
        return syscall(SYS_preadv, fd, iov, n, (long)off, 0L);
    if (!read_allowance(1))
        return read_eof ? 0 : (errno = EIO, -1);
    return account_vector(syscall(SYS_preadv, fd, iov, n, (long)off, 0L));
}

/* ------------------------------------------------------------ writes */

/* 1 if fd is a file under dir (a prefix of its /proc/self/fd link). */
static int under(int fd, const char *dir, size_t dir_len)
{
    if (!dir_len)
        return 0;
    char link[64], target[4096];
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    ssize_t n = readlink(link, target, sizeof target - 1);
    if (n <= 0)
        return 0;
    target[n] = '\0';
    return strncmp(target, dir, dir_len) == 0;
}

/* Reserves up to len bytes of the write budget; returns how many. */
static size_t write_allowance(size_t len)
{
    unsigned long long done = __atomic_load_n(&write_done, __ATOMIC_RELAXED);
    for (;;) {
        if (done >= write_after)
            return 0;
        size_t allow = write_after - done < len ? (size_t)(write_after - done) : len;
        if (__atomic_compare_exchange_n(&write_done, &done, done + allow, 0, __ATOMIC_RELAXED,
                                        __ATOMIC_RELAXED))
            return allow;
    }
}

ssize_t write(int fd, const void *buf, size_t len)
{
    if (len && under(fd, write_dir, write_dir_len)) {
        size_t allow = write_allowance(len);
        if (!allow)
            return errno = ENOSPC, -1;
        len = allow;
    }
    return syscall(SYS_write, fd, buf, len);
}

ssize_t pwrite(int fd, const void *buf, size_t len, off_t off)
{
    if (len && under(fd, write_dir, write_dir_len)) {
        size_t allow = write_allowance(len);
        if (!allow)
            return errno = ENOSPC, -1;
        len = allow;
    }
    return syscall(SYS_pwrite64, fd, buf, len, off);
}

ssize_t pwrite64(int fd, const void *buf, size_t len, off_t off)
{
    return pwrite(fd, buf, len, off);
}

ssize_t writev(int fd, const struct iovec *iov, int n)
{
    if (under(fd, write_dir, write_dir_len) && !write_allowance(1))
        return errno = ENOSPC, -1;
    return syscall(SYS_writev, fd, iov, n);
}

int fsync(int fd)
{
    if (under(fd, sync_dir, sync_dir_len))
        return errno = EIO, -1;
    return (int)syscall(SYS_fsync, fd);
}

int fdatasync(int fd)
{
    if (under(fd, sync_dir, sync_dir_len))
        return errno = EIO, -1;
    return (int)syscall(SYS_fdatasync, fd);
}

/* 1 if this close of fd must report a failure: a regular file under
 * close_dir (directories opened to be listed or removed are not the
 * storage's data) past the first close_after. */
static int close_fails(int fd)
{
    struct stat st;
    if (!under(fd, close_dir, close_dir_len) || fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
        return 0;
    return __atomic_add_fetch(&close_done, 1, __ATOMIC_RELAXED) > close_after;
}

int close(int fd)
{
    int fail = close_fails(fd);
    int rc = (int)syscall(SYS_close, fd);
    if (fail && rc == 0)
        return errno = ENOSPC, -1;
    return rc;
}

/* ------------------------------------------------------------ allocation */

/* Built with -DFAULT_NO_ALLOC for sanitizer builds of wpd: their allocator
 * must stay theirs (the I/O faults above still apply). */
#ifndef FAULT_NO_ALLOC

/* Called for every injected allocation failure: a breakpoint for finding
 * the call site (gdb -ex 'break fault_alloc_failed'). */
__attribute__((noinline)) void fault_alloc_failed(unsigned long long call, size_t size)
{
    __asm__ volatile("" : : "r"(call), "r"(size) : "memory");
}

/* 1 if this allocation call (of size bytes) must fail. */
static int alloc_fails(size_t size)
{
    if (!__atomic_load_n(&malloc_on, __ATOMIC_ACQUIRE))
        return 0;
    unsigned long long k = __atomic_add_fetch(&malloc_calls, 1, __ATOMIC_RELAXED);
    int fail = (malloc_above && size >= malloc_above) ||
               (malloc_fail && (k == malloc_fail || (malloc_always && k > malloc_fail)));
    if (fail)
        fault_alloc_failed(k, size);
    return fail;
}

void *malloc(size_t size)
{
    if (alloc_fails(size))
        return errno = ENOMEM, NULL;
    return __libc_malloc(size);
}

void *calloc(size_t n, size_t size)
{
    size_t bytes = n && size > SIZE_MAX / n ? SIZE_MAX : n * size;
    if (alloc_fails(bytes))
        return errno = ENOMEM, NULL;
    return __libc_calloc(n, size);
}

void *realloc(void *p, size_t size)
{
    if (alloc_fails(size))
        return errno = ENOMEM, NULL;
    return __libc_realloc(p, size);
}

int posix_memalign(void **out, size_t align, size_t size)
{
    if (align < sizeof(void *) || (align & (align - 1)))
        return EINVAL;
    if (alloc_fails(size))
        return ENOMEM;
    void *p = __libc_memalign(align, size);
    if (!p)
        return ENOMEM;
    *out = p;
    return 0;
}

void *aligned_alloc(size_t align, size_t size)
{
    if (alloc_fails(size))
        return errno = ENOMEM, NULL;
    return __libc_memalign(align, size);
}

void *memalign(size_t align, size_t size)
{
    if (alloc_fails(size))
        return errno = ENOMEM, NULL;
    return __libc_memalign(align, size);
}

void *valloc(size_t size)
{
    if (alloc_fails(size))
        return errno = ENOMEM, NULL;
    return __libc_memalign((size_t)sysconf(_SC_PAGESIZE), size);
}
#endif
