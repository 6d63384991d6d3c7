/* fullio.h - reads and writes that finish the job.
 *
 * read(2) and write(2) may move fewer bytes than asked (signals, pipes,
 * network file systems) and may fail with EINTR; every caller that wants
 * "all of it or a reason why" loops the same way. These do it once.
 */
#ifndef WPD_FULLIO_H
#define WPD_FULLIO_H

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

/* Reads len bytes of fd at offset off (the file position is not moved),
 * retrying EINTR and short reads. Returns the bytes read: len, or fewer
 * only when the file ends first; -1 with errno set on a read error. */
ssize_t wpd_pread_full(int fd, void *buf, size_t len, uint64_t off);

/* Writes all len bytes to fd at its current position, retrying EINTR and
 * short writes. Returns 0, or -1 with errno set; a write that makes no
 * progress is reported as ENOSPC (what a full disk does to some file
 * systems). */
int wpd_write_full(int fd, const void *buf, size_t len);

/* wpd_write_full at offset off, without moving the file position. */
int wpd_pwrite_full(int fd, const void *buf, size_t len, uint64_t off);

#endif
