/* commands.h - the wpd subcommands. Each takes argv with argv[0] = the
 * subcommand's name, prints its own errors as one line on stderr, and returns
 * the process exit status (0 ok, 1 usage, 2 bad input, 3 I/O, 4 memory). */
#ifndef WPD_COMMANDS_H
#define WPD_COMMANDS_H

#include "common/error.h"
#include "common/version.h"
#include "par/par.h"

int wpd_cmd_info(int argc, char **argv);
int wpd_cmd_convert(int argc, char **argv);
/* par: the ranks of an MPI run (wpd-mpi), which share the run and agree on
 * its outcome; rank 0 alone writes the output, progress and summary. */
int wpd_cmd_resample(int argc, char **argv, const wpd_par *par);
/* The help text of wpd resample (resample_usage.c). */
extern const char *const wpd_resample_usage;

/* Prints "wpd <command>: <msg>" on stderr and returns err->code. */
int wpd_report_error(const char *command, const wpd_error *err);

#endif
