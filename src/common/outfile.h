/* outfile.h - an output file that appears under its final name only when
 * complete: written to "<dir>/.<name>.wpd-tmp-<pid>-XXXXXX", then renamed. */
#ifndef WPD_OUTFILE_H
#define WPD_OUTFILE_H

#include <stdint.h>

#include "common/error.h"

typedef struct wpd_outfile {
    int fd;                  /* open for writing, -1 when closed */
    char final_path[1024];
    char temp_path[1100];
} wpd_outfile;

/* Creates the temporary file beside path. Fails (WPD_E_IO) when path exists
 * and overwrite is 0, or the directory is not writable. Returns 0 or -1. */
int wpd_outfile_open(wpd_outfile *f, const char *path, int overwrite, wpd_error *err);

/* Writes all len bytes at the current position. Returns 0, or -1 with err set
 * naming the output (disk full reported as such). */
int wpd_outfile_write(wpd_outfile *f, const void *buf, size_t len, wpd_error *err);

/* Writes all len bytes at absolute offset off (does not move the position). */
int wpd_outfile_pwrite(wpd_outfile *f, const void *buf, size_t len, long long off,
                       wpd_error *err);

/* Copies the first len bytes of part (open) into dest's temporary file
 * at offset off, through a descriptor of its own (dest may belong to
 * another process on another host: only dest->temp_path and final_path
 * are used), flushed to disk and closed. For one output written by
 * several processes (io/writer.h). Returns 0, or -1 with err set. */
int wpd_outfile_place(const wpd_outfile *part, uint64_t len, const wpd_outfile *dest,
                      uint64_t off, wpd_error *err);

/* Takes an exclusive lock on writing path, so that two runs writing the
 * same output cannot collide: flock on "<dir>/.<base>.wpd-lock". A lock
 * left by a killed run is released by the kernel, so it never blocks a
 * later run. Returns the lock's descriptor, or -1 with err set (WPD_E_IO:
 * "being written by another wpd run"). */
int wpd_output_lock(const char *path, wpd_error *err);

/* Releases a lock taken by wpd_output_lock and removes its file. */
void wpd_output_unlock(int fd, const char *path);

/* Removes temporary outputs of path (".<base>.wpd-tmp-<pid>-XXXXXX" in its
 * directory) left by runs that no longer exist (killed with SIGKILL, power
 * loss). Returns how many were removed. wpd_outfile_open calls it. */
int wpd_outfile_sweep_stale(const char *path);

/* 1 if path names an existing file that is also one of paths[0..n-1] (same
 * device and inode): writing it would destroy an input. */
int wpd_path_is_one_of(const char *path, char *const *paths, int n);

/* 1 if paths a and b name one file, whether it exists yet or not: the same
 * string, the same device and inode, or the same file name in the same
 * folder (folders compared as real paths, names byte by byte; otherwise 0
 * where a folder does not resolve). */
int wpd_path_same_place(const char *a, const char *b);

/* Flushes to disk, closes and renames over the final path. On failure the
 * temporary file is removed. Returns 0 or -1. */
int wpd_outfile_commit(wpd_outfile *f, wpd_error *err);

/* The two halves of wpd_outfile_commit, for outputs that must appear
 * together: finish flushes to disk and closes, leaving the complete file
 * under its temporary name; rename puts it in place. On failure either
 * removes the temporary file. Return 0 or -1. */
int wpd_outfile_finish(wpd_outfile *f, wpd_error *err);
int wpd_outfile_rename(wpd_outfile *f, wpd_error *err);

/* Closes and removes the temporary file. Safe to call twice. */
void wpd_outfile_abort(wpd_outfile *f);

/* Marks files[0..n-1] as holding nothing (abort and rename_all skip them),
 * before they are filled by wpd_writer_close_pending and the like. */
void wpd_outfile_clear_all(wpd_outfile *files, int n);

/* Renames the finished files[0..n-1] (wpd_outfile_finish done; cleared
 * ones are skipped) into place, in order, with SIGINT, SIGTERM and SIGHUP
 * held back until the last is renamed (wpd_tmpdir_hold_signals): a signal
 * cannot leave some in place and the others removed (it takes effect
 * after, the outputs complete).
 * On a failure the files not yet renamed are removed; those renamed stay
 * (renames in a directory that is still there do not fail). Returns 0 or
 * -1 with err naming the file. */
int wpd_outfile_rename_all(wpd_outfile *files, int n, wpd_error *err);

/* Removes every temporary file of files[0..n-1] not renamed yet. */
void wpd_outfile_abort_all(wpd_outfile *files, int n);

/* Flushes standard output. Returns 0, or -1 with err set (WPD_E_IO,
 * "standard output: <why>") when anything written to it was lost: a full
 * disk, an I/O error. */
int wpd_stdout_flush(wpd_error *err);

#endif
