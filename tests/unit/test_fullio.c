/* test_fullio.c - the full read and write loops (common/fullio.h). */
#include "harness.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include "common/fullio.h"

TEST(fullio_round_trip_and_end_of_file)
{
    char path[512];
    snprintf(path, sizeof path, "%s/fullio.bin", test_tmp_dir());
    int fd = open(path, O_RDWR | O_CREAT | O_TRUNC, 0600);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    static char big[3 << 20]; /* more than one pipe or page cache step */
    for (size_t i = 0; i < sizeof big; i++)
        big[i] = (char)(i * 7 + i / 4096);
    CHECK(wpd_write_full(fd, big, sizeof big) == 0);
    CHECK(lseek(fd, 0, SEEK_CUR) == (off_t)sizeof big);
    CHECK(wpd_pwrite_full(fd, "abcd", 4, 10) == 0);
    CHECK(lseek(fd, 0, SEEK_CUR) == (off_t)sizeof big); /* position not moved */
    static char back[sizeof big];
    CHECK(wpd_pread_full(fd, back, sizeof back, 0) == (ssize_t)sizeof back);
    memcpy(big + 10, "abcd", 4);
    CHECK(memcmp(back, big, sizeof big) == 0);
    /* Asking past the end gives what there is. */
    CHECK(wpd_pread_full(fd, back, 100, sizeof big - 30) == 30);
    CHECK(wpd_pread_full(fd, back, 100, sizeof big + 5) == 0);
    close(fd);
    /* A bad descriptor is an error with errno, not a short count. */
    errno = 0;
    CHECK(wpd_pread_full(fd, back, 1, 0) == -1 && errno == EBADF);
    CHECK(wpd_write_full(fd, big, 1) == -1 && errno == EBADF);
    unlink(path);
}
