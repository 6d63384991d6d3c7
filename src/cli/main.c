/* main.c - the wpd command: dispatch to subcommands. */
#include "cli/commands.h"
#include "tools/edges/edges.h"
#include "tools/metrics/metrics.h"
#include "tools/preview/preview.h"
#include "tools/synth/synth.h"

#include <malloc.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* A subcommand: run, or run_ranked for one that shares its work between
 * the ranks of an MPI run (par/par.h). Under wpd-mpi with several ranks
 * the others run on rank 0 alone (the other ranks exit with 0), so that an
 * `mpirun wpd-mpi convert ...` writes its output once. */
typedef struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    int (*run_ranked)(int argc, char **argv, const wpd_par *par);
    const char *summary;
} command;

static const command commands[] = {
    {"info", wpd_cmd_info, NULL,
     "describe LAS, LAZ and PLY files: format, count, bounds, schema, VLRs"},
    {"convert", wpd_cmd_convert, NULL,
     "stream points from one file (or several) into LAS, LAZ or PLY"},
    {"resample", NULL, wpd_cmd_resample, "resample to exactly N points (Weighted Poisson-disk)"},
    {"synth", wpd_synth_main, NULL, "generate a synthetic city-like LiDAR scan of any size"},
    {"metrics", wpd_metrics_main, NULL, "quality of a resampling: distances, density, spacing"},
    {"preview", wpd_preview_main, NULL,
     "draw a cloud, or two side by side with spacing histograms (PNG)"},
    {"edges", wpd_edges_main, NULL,
     "label the sharp features (creases) of a cloud, measure them"},
};

static void usage(FILE *f)
{
    fprintf(f, "usage: wpd <command> [options] ...\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof *commands; i++)
        fprintf(f, "  %-9s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\n'wpd <command> --help' describes a command.\n"
               "exit status: 0 success, 1 usage error, 2 bad input, 3 I/O error,\n"
               "4 memory budget too small or out of memory.\n");
}

/* Set when a command returns to main. An exit() that happens before that
 * comes from a runtime library giving up: libgomp calls exit(1) when it
 * cannot allocate a thread team or create a thread, which would read as a
 * usage error. The exit hook turns it into the memory exit code. */
static volatile int returned_to_main;

static void library_exit_is_a_memory_error(void)
{
    if (!returned_to_main)
        _exit(WPD_E_MEMORY);
}

static int dispatch(int argc, char **argv, const wpd_par *par);

int main(int argc, char **argv)
{
    /* Registered first so it runs last, after the hooks that remove
     * temporary files and spill directories. */
    atexit(library_exit_is_a_memory_error);
    /* A write past RLIMIT_FSIZE must fail with EFBIG and be reported like a
     * full disk (exit 3, outputs removed), not kill the process with
     * SIGXFSZ before it can clean up. */
    signal(SIGXFSZ, SIG_IGN);
    wpd_par *par = wpd_par_start(&argc, &argv);
    if (!par)
        return WPD_E_IO;
    int rc = dispatch(argc, argv, par);
    returned_to_main = 1;
    wpd_par_end(par);
    return rc;
}

static int dispatch(int argc, char **argv, const wpd_par *par)
{
    /* The pipeline allocates and frees tile-sized arrays over and over; with
     * glibc's defaults each one is a fresh mmap whose pages are faulted in
     * and zeroed again (a quarter of the engine's time on 10 M points).
     * Keeping freed memory in the heap makes them reusable; the peak, which
     * the memory budget bounds, does not change. The same holds for the
     * heap's top (trimmed back to the system at every large free by
     * default) and for the per-thread arenas, whose heaps are at most 64 MB
     * so that larger tile arrays are mmapped after all: one arena, never
     * trimmed. Measured on 100 M -> 1 M points, 2 threads: system time
     * 6.7 s -> 3.2 s, wall 23.6 s -> 21.0 s. */
    mallopt(M_MMAP_THRESHOLD, 256 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
    mallopt(M_ARENA_MAX, 1);
    if (argc < 2) {
        usage(stderr);
        return WPD_E_USAGE;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("wpd %s\n", WPD_VERSION);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof *commands; i++) {
        if (strcmp(argv[1], commands[i].name))
            continue;
        /* Every subcommand answers --version the same way. */
        for (int a = 2; a < argc && strcmp(argv[a], "--"); a++)
            if (!strcmp(argv[a], "--version")) {
                printf("wpd %s\n", WPD_VERSION);
                return 0;
            }
        if (commands[i].run_ranked)
            return commands[i].run_ranked(argc - 1, argv + 1, par);
        return wpd_par_rank(par) == 0 ? commands[i].run(argc - 1, argv + 1) : 0;
    }
    fprintf(stderr, "wpd: unknown command '%s' (see 'wpd --help')\n", argv[1]);
    return WPD_E_USAGE;
}

int wpd_report_error(const char *command, const wpd_error *err)
{
    fprintf(stderr, "wpd %s: %s\n", command, err->msg[0] ? err->msg : "failed");
    return err->code ? (int)err->code : WPD_E_IO;
}
