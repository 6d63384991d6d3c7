/* preview_cli.c - the `wpd preview` command line (see preview.h): options,
 * usage text, messages and exit statuses.
 */
#include "tools/preview/preview.h"
#include "common/outfile.h"
#include "io/reader.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *usage_text =
    "usage: wpd preview FILE -o OUT.png [--width W] [--height H] [--label DIM]\n"
    "                   [--crop X0,Y0,X1,Y1] [--force]\n"
    "       wpd preview BEFORE AFTER -o OUT.png [same options]\n"
    "Draws a LAS, LAZ or PLY point cloud as a PNG: an oblique orthographic view\n"
    "(elevation 35 degrees; azimuth 30, or another multiple of 30 that fills the\n"
    "picture clearly better) fitted to the image, coloured by the file's RGB\n"
    "when it has any, else by height (viridis). With two files, the\n"
    "two side by side in the same view and scale (BEFORE's bounds), each above\n"
    "a histogram of its nearest-neighbour spacing on a common axis (0 .. the\n"
    "larger 99th percentile; ticks at quarters, orange line = median). Point\n"
    "counts, axis range and colour range are printed and stored in the PNG's\n"
    "tEXt chunk. Memory does not depend on the input's size.\n"
    "  -o, --output FILE   the PNG to write; must not exist unless --force\n"
    "      --width W       image width in pixels (default 1200)\n"
    "      --height H      image height in pixels (default 700)\n"
    "      --label DIM     colour by dimension DIM: red where it is not 0, grey by\n"
    "                      height elsewhere (e.g. the edge label of resample\n"
    "                      --edge-label, or synth's edge_truth)\n"
    "      --crop X0,Y0,X1,Y1  draw only the points with X0 <= x < X1, Y0 <= y < Y1\n"
    "                      (the file's coordinates)\n"
    "      --force         replace OUT if it exists\n"
    "  -q, --quiet         print nothing on success\n";

static int parse_side(const char *text, int *out)
{
    char *end;
    long v = strtol(text, &end, 10);
    if (end == text || *end || v < WPD_PREVIEW_MIN_SIDE || v > WPD_PREVIEW_MAX_SIDE)
        return -1;
    *out = (int)v;
    return 0;
}

/* Parses "X0,Y0,X1,Y1" with X0 < X1 and Y0 < Y1 into opt's crop. */
static int parse_crop(const char *text, wpd_preview_options *opt)
{
    double v[4];
    int used = 0;
    if (sscanf(text, "%lf,%lf,%lf,%lf%n", &v[0], &v[1], &v[2], &v[3], &used) != 4 ||
        text[used] || !(v[0] < v[2] && v[1] < v[3]))
        return -1;
    opt->crop = 1;
    opt->crop_lo[0] = v[0], opt->crop_lo[1] = v[1];
    opt->crop_hi[0] = v[2], opt->crop_hi[1] = v[3];
    return 0;
}

int wpd_preview_main(int argc, char **argv)
{
    enum { OPT_WIDTH = 256, OPT_HEIGHT, OPT_FORCE, OPT_LABEL, OPT_CROP };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"width", required_argument, 0, OPT_WIDTH},
        {"height", required_argument, 0, OPT_HEIGHT}, {"force", no_argument, 0, OPT_FORCE},
        {"label", required_argument, 0, OPT_LABEL}, {"crop", required_argument, 0, OPT_CROP},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    const char *out = NULL;
    int quiet = 0, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': out = optarg; break;
        case 'q': quiet = 1; break;
        case OPT_FORCE: opt.overwrite = 1; break;
        case OPT_LABEL: opt.label = optarg; break;
        case OPT_CROP:
            if (parse_crop(optarg, &opt)) {
                fprintf(stderr, "wpd preview: --crop '%s': expected X0,Y0,X1,Y1 with X0 < X1 "
                        "and Y0 < Y1\n", optarg);
                return WPD_E_USAGE;
            }
            break;
        case 'h': fputs(usage_text, stdout); return 0;
        case OPT_WIDTH:
        case OPT_HEIGHT:
            if (parse_side(optarg, c == OPT_WIDTH ? &opt.width : &opt.height)) {
                fprintf(stderr, "wpd preview: --%s '%s': expected a whole number of pixels "
                        "%d..%d\n", c == OPT_WIDTH ? "width" : "height", optarg,
                        WPD_PREVIEW_MIN_SIDE, WPD_PREVIEW_MAX_SIDE);
                return WPD_E_USAGE;
            }
            break;
        default:
            if (optopt)
                fprintf(stderr, "wpd preview: option '-%c' %s (see 'wpd preview --help')\n",
                        optopt, strchr("o", optopt) ? "needs a value" : "is unknown");
            else
                fprintf(stderr, "wpd preview: unknown option '%s' or missing value (see 'wpd "
                        "preview --help')\n", argv[optind - 1]);
            return WPD_E_USAGE;
        }
    }
    int n = argc - optind;
    if (n < 1 || n > 2) {
        fprintf(stderr, "wpd preview: expected FILE or BEFORE AFTER, got %d file%s "
                "(see 'wpd preview --help')\n", n, n == 1 ? "" : "s");
        return WPD_E_USAGE;
    }
    if (!out) {
        fprintf(stderr, "wpd preview: no output: give -o OUT.png\n");
        return WPD_E_USAGE;
    }
    const char *const *paths = (const char *const *)argv + optind;
    wpd_error err = {0};
    wpd_preview_summary sum;
    int failed = wpd_preview_write(paths, n, out, &opt, &sum, &err);
    for (int i = 0; !quiet && i < n; i++)
        wpd_warnings_print(stderr, "preview", &sum.panel[i].warnings);
    if (failed) {
        fprintf(stderr, "wpd preview: %s\n", err.msg[0] ? err.msg : "failed");
        return err.code ? (int)err.code : WPD_E_IO;
    }
    if (!quiet) {
        char text[4096];
        wpd_preview_describe(&sum, paths, text, sizeof text);
        printf("%swrote %s (%d x %d)\n", text, out, sum.width, sum.height);
        /* OUT is in place and complete; a lost summary still fails. */
        if (wpd_stdout_flush(&err)) {
            fprintf(stderr, "wpd preview: %s\n", err.msg);
            return err.code;
        }
    }
    return 0;
}
