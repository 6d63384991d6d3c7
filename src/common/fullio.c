/* fullio.c - reads and writes that finish the job (see fullio.h). */
#include "common/fullio.h"

#include <errno.h>
#include <unistd.h>

ssize_t wpd_pread_full(int fd, void *buf, size_t len, uint64_t off)
{
    size_t done = 0;
    while (done < len) {
        ssize_t n = pread(fd, (char *)buf + done, len - done, (off_t)(off + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -1;
        if (n == 0)
            break;
        done += (size_t)n;
    }
    return (ssize_t)done;
}

/* The one write loop: at off, or at the file position when at_pos. */
static int write_loop(int fd, const char *p, size_t len, uint64_t off, int at_pos)
{
    while (len) {
        ssize_t w = at_pos ? write(fd, p, len) : pwrite(fd, p, len, (off_t)off);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            if (w == 0)
                errno = ENOSPC;
            return -1;
        }
        p += w;
        len -= (size_t)w;
        off += (uint64_t)w;
    }
    return 0;
}

int wpd_write_full(int fd, const void *buf, size_t len)
{
    return write_loop(fd, buf, len, 0, 1);
}

int wpd_pwrite_full(int fd, const void *buf, size_t len, uint64_t off)
{
    return write_loop(fd, buf, len, off, 0);
}
