/* synth_cli.c - the `wpd synth` command line (see synth.h): option
 * parsing with k/M/G counts, the usage text, the one-line summary, and
 * the mapping of errors to exit statuses.
 */
#include "tools/synth/synth.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tools/synth/synth_output.h"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: wpd synth -n N -o OUT [--seed S] [--tiles K] [--edge-truth] [--oblique]\n"
            "                 [--ascii] [--force]\n"
            "\n"
            "Writes a synthetic city-like airborne LiDAR scan of exactly N points\n"
            "(terrain, streets, buildings with walls and roofs, trees with multiple\n"
            "returns, a little noise; overlapping flight strips; ~12 points/m2).\n"
            "\n"
            "  -n N         number of points (suffixes k, M, G: 10^3, 10^6, 10^9)\n"
            "  -o OUT       output file; format from the extension: .las (LAS 1.2,\n"
            "               point format 3; LAS 1.4 above 2^32-1 points) or .ply\n"
            "               (binary little-endian)\n"
            "  --seed S     random seed (default 1); same N and S give the same bytes\n"
            "  --tiles K    write K files OUT_tile1 .. OUT_tileK (1..%d), one per cell\n"
            "               of a near-square grid over the scene\n"
            "  --edge-truth add the field edge_truth: for the points within half the\n"
            "               point spacing (pulse spacing 0.35-0.38 m) of a building\n"
            "               crease of 30 degrees\n"
            "               or more, the kind of the nearest: 1 ridge, 2 wall top\n"
            "               (eaves), 3 wall corner, 4 wall foot; 0 elsewhere (LAS: an\n"
            "               extra byte with its Extra Bytes VLR; PLY: uchar)\n"
            "  --oblique    the oblique survey: strips north/south and east/west,\n"
            "               pulses leaning 35-65 degrees to either side, so walls\n"
            "               facing any way carry points (the same scene; the point\n"
            "               spacing of --edge-truth is then that of all strips\n"
            "               together, about 0.3 m)\n"
            "  --ascii      ascii PLY\n"
            "  --force      overwrite existing output files\n"
            "  --help       this text\n"
            "\n"
            "exit status: 0 success, 1 usage error (also: OUT exists, no --force),\n"
            "2 bad value, 3 I/O error, 4 out of memory.\n",
            WPD_SYNTH_MAX_TILES);
}

static int cli_fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prints "wpd synth: <message>" on stderr; returns code. */
static int cli_fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "wpd synth: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}

/* Parses a non-negative decimal integer with an optional k/M/G suffix. */
static int parse_count(const char *s, uint64_t *out)
{
    if (!*s || *s == '-' || *s == '+')
        return -1;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s)
        return -1;
    uint64_t mul = 1;
    if (*end == 'k' || *end == 'K')
        mul = 1000, end++;
    else if (*end == 'm' || *end == 'M')
        mul = 1000000, end++;
    else if (*end == 'g' || *end == 'G')
        mul = 1000000000, end++;
    if (*end || v > UINT64_MAX / mul)
        return -1;
    *out = v * mul;
    return 0;
}

/* Value of option argv[*i] ("--opt value" or "--opt=value"); NULL if missing. */
static const char *option_value(int argc, char **argv, int *i, const char *name)
{
    size_t n = strlen(name);
    if (argv[*i][n] == '=')
        return argv[*i] + n + 1;
    return *i + 1 < argc ? argv[++*i] : NULL;
}

static int option_is(const char *arg, const char *name)
{
    size_t n = strlen(name);
    return !strncmp(arg, name, n) && (arg[n] == '\0' || (arg[n] == '=' && name[1] == '-'));
}

/* The option with a value that arg names, or NULL. */
static const char *valued_option(const char *arg)
{
    static const char *const names[] = {"-n", "-o", "--seed", "--tiles"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (option_is(arg, names[i]))
            return names[i];
    return NULL;
}

/* Stores the value v of numeric option name. Returns 0 or an exit status. */
static int set_number(wpd_synth_options *opt, const char *name, const char *v)
{
    uint64_t num;
    if (parse_count(v, &num))
        return cli_fail(WPD_E_INPUT, "%s: bad number '%s'", name, v);
    if (!strcmp(name, "--seed")) {
        opt->seed = num;
    } else if (!strcmp(name, "-n")) {
        if (num < 1)
            return cli_fail(WPD_E_INPUT, "-n: the point count must be at least 1");
        opt->points = num;
    } else {
        if (num < 1 || num > WPD_SYNTH_MAX_TILES)
            return cli_fail(WPD_E_INPUT, "--tiles: %s is not in 1..%d", v, WPD_SYNTH_MAX_TILES);
        opt->tiles = (int)num;
    }
    return 0;
}

/* Fills *opt from the command line. Returns -1 to go on, else the exit
 * status to return (0 after --help). */
static int parse_args(int argc, char **argv, wpd_synth_options *opt)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *name, *v;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--ascii")) {
            opt->ply_ascii = 1;
        } else if (!strcmp(a, "--force")) {
            opt->overwrite = 1;
        } else if (!strcmp(a, "--edge-truth")) {
            opt->edge_truth = 1;
        } else if (!strcmp(a, "--oblique")) {
            opt->oblique = 1;
        } else if ((name = valued_option(a))) {
            if (!(v = option_value(argc, argv, &i, name)))
                return cli_fail(WPD_E_USAGE, "option %s needs a value (see 'wpd synth --help')",
                                name);
            int rc = 0;
            if (!strcmp(name, "-o"))
                opt->output = v;
            else if ((rc = set_number(opt, name, v)))
                return rc;
        } else {
            return cli_fail(WPD_E_USAGE, "unknown option '%s' (see 'wpd synth --help')", a);
        }
    }
    if (!opt->points || !opt->output)
        return cli_fail(WPD_E_USAGE, "need -n N and -o OUT (see 'wpd synth --help')");
    return -1;
}

static void print_summary(const wpd_synth_options *opt, const wpd_synth_summary *sum)
{
    char files[2200];
    if (sum->files == 1) {
        snprintf(files, sizeof files, "%s", opt->output);
    } else {
        char first[1024], last[1024];
        wpd_synth_tile_path(opt->output, 1, first, sizeof first);
        wpd_synth_tile_path(opt->output, sum->files, last, sizeof last);
        snprintf(files, sizeof files, "%d tiles (%dx%d) %s .. %s", sum->files, sum->columns,
                 sum->rows, first, last);
    }
    printf("wrote %" PRIu64 " points to %s: x %.2f .. %.2f, y %.2f .. %.2f, z %.2f .. %.2f"
           " (%.0f m scene, %d strips, seed %" PRIu64 ")\n",
           sum->points, files, sum->min[0], sum->max[0], sum->min[1], sum->max[1], sum->min[2],
           sum->max[2], sum->side, sum->strips, opt->seed);
}

int wpd_synth_main(int argc, char **argv)
{
    wpd_synth_options opt = {.seed = 1, .tiles = 1};
    int rc = parse_args(argc, argv, &opt);
    if (rc >= 0)
        return rc;
    wpd_error err;
    wpd_error_clear(&err);
    wpd_synth_options checked;
    if (synth_check_options(&opt, &checked, &err))
        return cli_fail(WPD_E_INPUT, "%s", err.msg);
    wpd_synth_summary sum;
    if (wpd_synth_generate(&checked, &sum, &err))
        return cli_fail(err.code ? (int)err.code : WPD_E_IO, "%s", err.msg);
    print_summary(&opt, &sum);
    /* The files are in place and complete; a lost summary still fails. */
    if (wpd_stdout_flush(&err))
        return cli_fail(err.code, "%s", err.msg);
    return 0;
}
