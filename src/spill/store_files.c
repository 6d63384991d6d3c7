/* store_files.c - the spill's tile files (see store.h): their paths, the
 * cache of descriptors open for writing, and whole-range reads and writes.
 *
 * Files: "<dir>/tile-NNNNNN", one per tile that received points. Writers
 * append through positioned writes into ranges reserved under the lock, so
 * several compression threads can write to one file at once; at most
 * MAX_OPEN_FILES descriptors stay open (tiles can be thousands, and the
 * descriptor limit is often 1024).
 */
#include "spill/store.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

void spill_tile_path(const wpd_spill *s, int t, char *out, size_t len)
{
    snprintf(out, len, "%s/tile-%06d", s->dir, t);
}

/* Closes fd, a descriptor tile t was written through. Storage that reports
 * a lost write only at close (NFS, quotas) fails the spill: the tile's
 * file would be read back short or damaged. Lock held. */
void spill_close_tile_fd_locked(wpd_spill *s, int fd, int t)
{
    if (close(fd) == 0)
        return;
    wpd_error e;
    char path[1100];
    spill_tile_path(s, t, path, sizeof path);
    wpd_fail_errno(&e, "%s: cannot close spill file", path);
    spill_set_failed_locked(s, &e);
}

/* An open descriptor for writing tile t, pinned (not closed by another
 * thread until unpinned): cached, or opened in the least recently used
 * unpinned slot (at most MAX_OPEN_FILES stay open). *slot is -1 for a
 * descriptor outside the cache (every slot pinned), which the caller
 * closes. Lock held. Returns -1 if the file cannot be opened. */
int spill_tile_fd_locked(wpd_spill *s, int t, int *slot_out)
{
    tile *T = &s->tiles[t];
    if (T->fd_slot >= 0) {
        s->open_files[T->fd_slot].used = ++s->clock;
        s->open_files[T->fd_slot].pins++;
        *slot_out = T->fd_slot;
        return s->open_files[T->fd_slot].fd;
    }
    int slot = -1;
    for (int k = 0; k < MAX_OPEN_FILES; k++) {
        if (s->open_files[k].pins)
            continue;
        if (s->open_files[k].fd < 0) {
            slot = k;
            break;
        }
        if (slot < 0 || s->open_files[k].used < s->open_files[slot].used)
            slot = k;
    }
    if (slot >= 0 && s->open_files[slot].fd >= 0) {
        spill_close_tile_fd_locked(s, s->open_files[slot].fd, s->open_files[slot].tile);
        s->tiles[s->open_files[slot].tile].fd_slot = -1;
        s->open_files[slot].fd = -1;
    }
    char path[1100];
    spill_tile_path(s, t, path, sizeof path);
    int fd = open(path, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
    *slot_out = fd >= 0 ? slot : -1;
    if (fd < 0 || slot < 0)
        return fd;
    s->open_files[slot].fd = fd;
    s->open_files[slot].tile = t;
    s->open_files[slot].used = ++s->clock;
    s->open_files[slot].pins = 1;
    T->fd_slot = slot;
    return fd;
}

/* Closes every cached descriptor (writing is over); a failure fails the
 * spill. */
void spill_close_files(wpd_spill *s)
{
    pthread_mutex_lock(&s->mu);
    for (int k = 0; k < MAX_OPEN_FILES; k++)
        if (s->open_files[k].fd >= 0) {
            spill_close_tile_fd_locked(s, s->open_files[k].fd, s->open_files[k].tile);
            s->tiles[s->open_files[k].tile].fd_slot = -1;
            s->open_files[k].fd = -1;
        }
    pthread_mutex_unlock(&s->mu);
}

