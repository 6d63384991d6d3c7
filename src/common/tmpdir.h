/* tmpdir.h - private temporary directories removed on every exit path.
 *
 * A run's spill directory must disappear whether the run succeeds, fails,
 * or is stopped by SIGINT, SIGTERM or SIGHUP; and one left behind by a run
 * that was killed outright (SIGKILL, power loss) must be recognised and
 * removed by a later run. This module keeps the one piece of process-wide
 * state wpd has - the list of directories to remove, which a signal handler
 * must be able to reach - and nothing else.
 */
#ifndef WPD_TMPDIR_H
#define WPD_TMPDIR_H

#include <stddef.h>

#include "common/error.h"

/* Creates "<base>/<prefix>-<pid>-XXXXXX" (mode 0700), registers it for
 * removal and writes its path to out (size outlen). Installs the signal
 * handlers on first use: on SIGINT/SIGTERM/SIGHUP every registered
 * directory is emptied and removed (async-signal-safe), then the signal is
 * re-raised with the default action so the exit status says what happened
 * (130 / 143 from a shell). Returns 0 or -1 (WPD_E_IO naming base). */
int wpd_tmpdir_create(const char *base, const char *prefix, char *out, size_t outlen,
                      wpd_error *err);

/* Empties and removes a directory created above and unregisters it. */
void wpd_tmpdir_remove(const char *path);

/* Registers a temporary output file to be removed on SIGINT/SIGTERM/SIGHUP
 * and at exit, until wpd_tmpdir_untrack_file (after its rename). Returns 0,
 * or -1 when the registry is full (the file is then only removed by the
 * normal error paths and by the next run's sweep). */
int wpd_tmpdir_track_file(const char *path);

/* Stops tracking path (it was renamed into place or removed). */
void wpd_tmpdir_untrack_file(const char *path);

/* Registers dir so that on SIGINT/SIGTERM/SIGHUP and at exit every entry
 * of it named like a temporary output of this process (containing
 * ".wpd-tmp-<host>-<pid>-") is removed: for runs that keep many finished outputs
 * under temporary names until all can be renamed, more than the registry
 * could hold one by one. Returns 0, or -1 when the registry is full. */
int wpd_tmpdir_track_outputs(const char *dir);

/* Stops tracking dir's temporary outputs (they were renamed or removed). */
void wpd_tmpdir_untrack_outputs(const char *dir);

/* Holds back what SIGINT, SIGTERM and SIGHUP do, whichever thread takes
 * them (blocking them on one thread would only send them to another, an
 * OpenMP worker), until wpd_tmpdir_release_signals: the last release
 * then removes everything registered and dies of the signal taken
 * meanwhile, if any. For a few steps that must not be cut in the middle:
 * creating a temporary file and registering it, renaming a set of outputs
 * that appear together. Holds may overlap (nested, or on several
 * threads): the signal takes effect at the last release. */
void wpd_tmpdir_hold_signals(void);
void wpd_tmpdir_release_signals(void);

/* The host tag in temporary names, "<prefix>-<host>-<pid>-XXXXXX": a pid
 * means something only on its host, and a tmpdir or output folder may be
 * shared between hosts (the ranks of an MPI run, cron on several servers
 * over NFS). The short host name, other characters than letters, digits
 * and '-' as '_', at most WPD_HOST_TAG_MAX of them. */
#define WPD_HOST_TAG_MAX 32
void wpd_tmpdir_host(char *out, size_t size);

/* Removes the entries of dir named "<prefix><host>-<pid>-XXXXXX" (XXXXXX:
 * the 6 letters and digits mkstemp and mkdtemp add), host this host's tag,
 * whose pid is no longer a running process: what a run killed outright
 * (SIGKILL, power loss) left. Names without a host tag (earlier versions)
 * count as this host's; other hosts' are never touched. dirs 1:
 * directories of this user, with all they hold; dirs 0: plain files.
 * Never touches the calling process's own. Returns how many were
 * removed. */
int wpd_tmpdir_sweep_dead(const char *dir, const char *prefix, int dirs);

/* Removes "<base>/<prefix>-<host>-<pid>-*" directories of this host whose
 * pid is no longer a running process (wpd_tmpdir_sweep_dead). Returns how many were removed. */
int wpd_tmpdir_sweep_stale(const char *base, const char *prefix);

#endif
