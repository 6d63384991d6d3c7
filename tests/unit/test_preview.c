/* test_preview.c - `wpd preview` (tools/preview.c) on synthetic PLY clouds:
 * picture size and variety, both panels of a comparison, colour detection
 * (8- and 16-bit), spacing measured in the full cloud even when windowed,
 * errors (missing input, existing output) leaving no file behind, and
 * byte-identical output for the same input whatever the thread count. */
#include "harness.h"
#include "tools/preview/preview.h"

#include <dirent.h>
#include <math.h>
#include <png.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ------------------------------------------------------------------ helpers */

static void tmp_path(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", test_tmp_dir(), name);
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Colour kinds of the synthetic files. */
enum { NO_RGB, RGB8, RGB16 };

/* A point of the scene: ground sloping up along x with a box-shaped
 * building, on a square lattice of the given pitch (every `thin`-th point
 * kept). Writes a binary little-endian PLY; returns the number of points or
 * -1. Coloured files get a red-to-blue gradient along x. */
static long write_scene(const char *path, int side, double pitch, int thin, int rgb)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    long n = 0;
    for (long k = 0; k < (long)side * side; k++)
        n += k % thin == 0;
    const char *ctype = rgb == RGB16 ? "ushort" : "uchar";
    fprintf(f, "ply\nformat binary_little_endian 1.0\nelement vertex %ld\n"
               "property double x\nproperty double y\nproperty double z\n", n);
    if (rgb != NO_RGB)
        fprintf(f, "property %s red\nproperty %s green\nproperty %s blue\n", ctype, ctype, ctype);
    fprintf(f, "end_header\n");
    double extent = side * pitch;
    for (long k = 0; k < (long)side * side; k++) {
        if (k % thin)
            continue;
        double x = (double)(k % side) * pitch, y = (double)(k / side) * pitch;
        double z = 0.05 * x;
        if (fabs(x - extent / 2) < extent / 6 && fabs(y - extent / 2) < extent / 6)
            z += extent / 8; /* the building's roof */
        double p[3] = {512000.0 + x, 4300000.0 + y, 100.0 + z};
        fwrite(p, sizeof p, 1, f);
        double t = x / extent;
        if (rgb == RGB8) {
            uint8_t c[3] = {(uint8_t)(255 * (1 - t)), 60, (uint8_t)(255 * t)};
            fwrite(c, 1, 3, f);
        } else if (rgb == RGB16) {
            uint16_t c[3] = {(uint16_t)(65535 * (1 - t)), 15000, (uint16_t)(65535 * t)};
            fwrite(c, 2, 3, f);
        }
    }
    return fclose(f) == 0 ? n : -1;
}

/* Decodes a PNG file into RGB (free() *rgb). Returns 0 or -1. */
static int read_png(const char *path, uint8_t **rgb, int *w, int *h)
{
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, path))
        return -1;
    im.format = PNG_FORMAT_RGB;
    *rgb = malloc(PNG_IMAGE_SIZE(im));
    if (!*rgb || !png_image_finish_read(&im, NULL, *rgb, 0, NULL)) {
        free(*rgb);
        png_image_free(&im);
        return -1;
    }
    *w = (int)im.width;
    *h = (int)im.height;
    return 0;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Distinct colours among the pixels of rectangle (x0, y0, w, h) of an
 * image of width iw. */
static size_t distinct_colours(const uint8_t *rgb, int iw, int x0, int y0, int w, int h)
{
    uint32_t *c = malloc((size_t)w * h * sizeof *c);
    size_t n = 0;
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x++) {
            const uint8_t *p = rgb + 3 * ((size_t)y * iw + x);
            c[n++] = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
        }
    qsort(c, n, sizeof *c, cmp_u32);
    size_t d = n ? 1 : 0;
    for (size_t i = 1; i < n; i++)
        d += c[i] != c[i - 1];
    free(c);
    return d;
}

/* Pixels of the rectangle that differ from the top-left pixel (background). */
static size_t drawn_pixels(const uint8_t *rgb, int iw, int x0, int y0, int w, int h)
{
    size_t n = 0;
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x++)
            n += memcmp(rgb + 3 * ((size_t)y * iw + x), rgb, 3) != 0;
    return n;
}

static int read_file(const char *path, uint8_t **data, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    fseek(f, 0, SEEK_END);
    *len = (size_t)ftell(f);
    rewind(f);
    *data = malloc(*len ? *len : 1);
    size_t got = *data ? fread(*data, 1, *len, f) : 0;
    fclose(f);
    return got == *len ? 0 : -1;
}

/* 1 if the directory holds a leftover temporary output. */
static int has_temp_file(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int found = 0;
    while (d && (e = readdir(d)))
        found |= strstr(e->d_name, ".wpd-tmp") != NULL;
    if (d)
        closedir(d);
    return found;
}

/* -------------------------------------------------------------------- tests */

TEST(preview_single_has_requested_size_and_many_colours)
{
    char in[512], out[512];
    tmp_path(in, sizeof in, "pv_scene.ply");
    tmp_path(out, sizeof out, "pv_scene.png");
    CHECK(write_scene(in, 200, 0.5, 1, NO_RGB) == 40000);
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 640;
    opt.height = 360;
    wpd_preview_summary s;
    wpd_error err = {0};
    const char *paths[1] = {in};
    CHECK_MSG(wpd_preview_write(paths, 1, out, &opt, &s, &err) == 0, "%s", err.msg);
    uint8_t *rgb = NULL;
    int w = 0, h = 0;
    CHECK(read_png(out, &rgb, &w, &h) == 0);
    CHECK_MSG(w == 640 && h == 360, "%d x %d", w, h);
    if (rgb) {
        /* A shaded, height-coloured scene, not a flat fill: the view the
         * preview picks for this scene draws 19 colours (background
         * included); a flat or unshaded image gives 2 or 3. */
        size_t colours = distinct_colours(rgb, w, 0, 0, w, h);
        CHECK_MSG(colours >= 12, "only %zu colours", colours);
        size_t drawn = drawn_pixels(rgb, w, 0, 0, w, h);
        CHECK_MSG(drawn > (size_t)w * h / 10, "only %zu pixels drawn", drawn);
    }
    free(rgb);
    CHECK(s.panels == 1 && s.panel[0].points == 40000 && s.panel[0].drawn == 40000);
    CHECK(s.panel[0].by_rgb == 0 && s.panel[0].stride == 1);
    CHECK(s.panel[0].point_size >= 1 && s.panel[0].point_size <= 3);
    /* the lattice's spacing is exactly the pitch */
    CHECK_MSG(fabs(s.panel[0].spacing_median - 0.5) < 1e-9, "median %g", s.panel[0].spacing_median);
    CHECK(s.z_hi > s.z_lo);
    /* the numbers are in the tEXt chunk too */
    uint8_t *bytes = NULL;
    size_t len = 0;
    CHECK(read_file(out, &bytes, &len) == 0);
    CHECK(bytes && memmem(bytes, len, "tEXtDescription", 15) != NULL);
    CHECK(bytes && memmem(bytes, len, "40000 points", 12) != NULL);
    free(bytes);
}

TEST(preview_comparison_has_both_panels_and_histograms)
{
    char before[512], after[512];
    tmp_path(before, sizeof before, "pv_before.ply");
    tmp_path(after, sizeof after, "pv_after.ply");
    CHECK(write_scene(before, 200, 0.5, 1, NO_RGB) == 40000);
    CHECK(write_scene(after, 200, 0.5, 7, NO_RGB) > 5000);
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 800;
    opt.height = 500;
    wpd_preview_image img;
    wpd_preview_summary s;
    wpd_error err = {0};
    const char *paths[2] = {before, after};
    CHECK_MSG(wpd_preview_render(paths, 2, &opt, &img, &s, &err) == 0, "%s", err.msg);
    CHECK(img.width == 800 && img.height == 500 && s.panels == 2);
    if (img.rgb) {
        int half = 800 / 2 - 2, hist_h = 500 / 4, view_h = 500 - hist_h;
        /* each column: a picture above, bars below */
        for (int c = 0; c < 2; c++) {
            int x0 = c ? 800 - half : 0;
            size_t view = drawn_pixels(img.rgb, 800, x0, 0, half, view_h);
            size_t hist = drawn_pixels(img.rgb, 800, x0, view_h, half, hist_h);
            CHECK_MSG(view > 5000, "panel %d: %zu pixels drawn", c, view);
            CHECK_MSG(hist > 500, "panel %d: histogram of %zu pixels", c, hist);
        }
    }
    /* thinned: larger spacing; one common axis */
    CHECK(s.panel[1].spacing_median > s.panel[0].spacing_median);
    CHECK(s.hist_max >= s.panel[0].spacing_p99 && s.hist_max >= s.panel[1].spacing_p99);
    CHECK(s.hist_max == s.panel[0].spacing_p99 || s.hist_max == s.panel[1].spacing_p99);
    wpd_preview_image_free(&img);
}

TEST(preview_colours_from_rgb_8_and_16_bit)
{
    static const int kinds[2] = {RGB8, RGB16};
    for (int k = 0; k < 2; k++) {
        char in[512];
        tmp_path(in, sizeof in, k ? "pv_rgb16.ply" : "pv_rgb8.ply");
        CHECK(write_scene(in, 100, 1.0, 1, kinds[k]) == 10000);
        wpd_preview_options opt;
        wpd_preview_defaults(&opt);
        opt.width = 300;
        opt.height = 200;
        wpd_preview_image img;
        wpd_preview_summary s;
        wpd_error err = {0};
        const char *paths[1] = {in};
        CHECK_MSG(wpd_preview_render(paths, 1, &opt, &img, &s, &err) == 0, "%s", err.msg);
        CHECK(s.panel[0].by_rgb == 1);
        CHECK_MSG(s.panel[0].rgb_bits == (k ? 16 : 8), "bits %d", s.panel[0].rgb_bits);
        /* a red-to-blue gradient: some pixel is clearly red, another blue
         * (with the wrong bit depth 16-bit values would saturate at white
         * and 8-bit ones would be near black) */
        int red = 0, blue = 0;
        for (size_t i = 0; img.rgb && i < (size_t)img.width * img.height; i++) {
            const uint8_t *p = img.rgb + 3 * i;
            red |= p[0] > 180 && p[2] < 80;
            blue |= p[2] > 180 && p[0] < 80;
        }
        CHECK_MSG(red && blue, "kind %d: red %d blue %d", k, red, blue);
        wpd_preview_image_free(&img);
    }
}

TEST(preview_large_cloud_spacing_measured_in_windows)
{
    /* 600 x 600 lattice of pitch 0.25: more points than the sample holds, so
     * the spacing comes from windows; every distance must still be the
     * pitch (a thinned cloud would report a larger one) */
    char in[512];
    tmp_path(in, sizeof in, "pv_large.ply");
    CHECK(write_scene(in, 600, 0.25, 1, NO_RGB) == 360000);
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 256;
    opt.height = 160;
    wpd_preview_image img;
    wpd_preview_summary s;
    wpd_error err = {0};
    const char *paths[1] = {in};
    CHECK_MSG(wpd_preview_render(paths, 1, &opt, &img, &s, &err) == 0, "%s", err.msg);
    CHECK(s.panel[0].points == 360000);
    CHECK_MSG(s.panel[0].spacing_count > 1000 && s.panel[0].spacing_count <= WPD_PREVIEW_SAMPLE_MAX,
              "%llu measured", (unsigned long long)s.panel[0].spacing_count);
    CHECK_MSG(fabs(s.panel[0].spacing_median - 0.25) < 1e-9, "median %g",
              s.panel[0].spacing_median);
    CHECK_MSG(fabs(s.panel[0].spacing_p99 - 0.25) < 1e-9, "p99 %g", s.panel[0].spacing_p99);
    /* 64 points per pixel at most: 256 x 160 x 64 > 360000, so all drawn */
    CHECK(s.panel[0].stride == 1);
    wpd_preview_image_free(&img);
}

TEST(preview_missing_input_fails_without_output)
{
    char in[512], out[512];
    tmp_path(in, sizeof in, "pv_does_not_exist.las");
    tmp_path(out, sizeof out, "pv_missing.png");
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    wpd_error err = {0};
    const char *paths[1] = {in};
    CHECK(wpd_preview_write(paths, 1, out, &opt, NULL, &err) == -1);
    CHECK_MSG(err.code == WPD_E_IO || err.code == WPD_E_INPUT, "code %d", err.code);
    CHECK_MSG(strstr(err.msg, "pv_does_not_exist.las") != NULL, "%s", err.msg);
    CHECK(!file_exists(out));
    CHECK(!has_temp_file(test_tmp_dir()));
    /* the command: exit status and one line naming the file */
    char *argv[] = {"preview", in, "-o", out, NULL};
    FILE *saved = stderr;
    stderr = fopen("/dev/null", "w");
    int rc = wpd_preview_main(4, argv);
    fclose(stderr);
    stderr = saved;
    CHECK_MSG(rc == WPD_E_IO || rc == WPD_E_INPUT, "exit %d", rc);
    CHECK(!file_exists(out));
}

TEST(preview_existing_output_needs_force)
{
    char in[512], out[512];
    tmp_path(in, sizeof in, "pv_force.ply");
    tmp_path(out, sizeof out, "pv_force.png");
    CHECK(write_scene(in, 50, 1.0, 1, NO_RGB) == 2500);
    FILE *f = fopen(out, "w");
    if (f) {
        fputs("keep me", f);
        fclose(f);
    }
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 200;
    opt.height = 120;
    wpd_error err = {0};
    const char *paths[1] = {in};
    CHECK(wpd_preview_write(paths, 1, out, &opt, NULL, &err) == -1);
    CHECK(err.code == WPD_E_USAGE);
    struct stat st;
    CHECK(stat(out, &st) == 0 && st.st_size == 7);
    opt.overwrite = 1;
    CHECK_MSG(wpd_preview_write(paths, 1, out, &opt, NULL, &err) == 0, "%s", err.msg);
    CHECK(stat(out, &st) == 0 && st.st_size > 100);
    /* an input is never the output */
    CHECK(wpd_preview_write(paths, 1, in, &opt, NULL, &err) == -1 && err.code == WPD_E_USAGE);
    CHECK(!has_temp_file(test_tmp_dir()));
}

TEST(preview_same_input_same_bytes)
{
    char before[512], after[512], out1[512], out2[512];
    tmp_path(before, sizeof before, "pv_det_before.ply");
    tmp_path(after, sizeof after, "pv_det_after.ply");
    tmp_path(out1, sizeof out1, "pv_det1.png");
    tmp_path(out2, sizeof out2, "pv_det2.png");
    CHECK(write_scene(before, 150, 0.5, 1, RGB8) > 0);
    CHECK(write_scene(after, 150, 0.5, 5, RGB8) > 0);
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 500;
    opt.height = 300;
    wpd_error err = {0};
    const char *paths[2] = {before, after};
    opt.threads = 1;
    CHECK_MSG(wpd_preview_write(paths, 2, out1, &opt, NULL, &err) == 0, "%s", err.msg);
    opt.threads = 4;
    CHECK_MSG(wpd_preview_write(paths, 2, out2, &opt, NULL, &err) == 0, "%s", err.msg);
    uint8_t *a = NULL, *b = NULL;
    size_t la = 0, lb = 0;
    CHECK(read_file(out1, &a, &la) == 0 && read_file(out2, &b, &lb) == 0);
    CHECK_MSG(la == lb && a && b && memcmp(a, b, la) == 0, "%zu vs %zu bytes", la, lb);
    free(a);
    free(b);
}

TEST(preview_command_line)
{
    char *help[] = {"preview", "--help", NULL};
    FILE *saved = stdout;
    stdout = fopen("/dev/null", "w");
    int rc = wpd_preview_main(2, help);
    fclose(stdout);
    stdout = saved;
    CHECK(rc == 0);
    saved = stderr;
    stderr = fopen("/dev/null", "w");
    char *none[] = {"preview", NULL};
    int none_rc = wpd_preview_main(1, none);
    char *no_out[] = {"preview", "a.las", NULL};
    int no_out_rc = wpd_preview_main(2, no_out);
    char *bad_width[] = {"preview", "a.las", "-o", "x.png", "--width", "12", NULL};
    int bad_width_rc = wpd_preview_main(6, bad_width);
    char *three[] = {"preview", "a", "b", "c", "-o", "x.png", NULL};
    int three_rc = wpd_preview_main(6, three);
    fclose(stderr);
    stderr = saved;
    CHECK(none_rc == WPD_E_USAGE && no_out_rc == WPD_E_USAGE);
    CHECK(bad_width_rc == WPD_E_USAGE && three_rc == WPD_E_USAGE);
}

TEST(preview_real_scan_if_present)
{
    const char *dir = test_data_dir();
    if (!dir)
        return;
    char in[1024];
    snprintf(in, sizeof in, "%s/scans/lone-star_tile1.las", dir);
    if (!file_exists(in))
        return;
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 400;
    opt.height = 240;
    wpd_preview_image img;
    wpd_preview_summary s;
    wpd_error err = {0};
    const char *paths[1] = {in};
    CHECK_MSG(wpd_preview_render(paths, 1, &opt, &img, &s, &err) == 0, "%s", err.msg);
    CHECK(s.panel[0].points == 122893);
    CHECK(img.rgb && drawn_pixels(img.rgb, img.width, 0, 0, img.width, img.height) > 5000);
    wpd_preview_image_free(&img);
}

TEST(preview_label_colours_red_and_crop_draws_a_part)
{
    /* The scene coloured by its red channel as a label: red where it is
     * not 0 (x below 255/256 of the extent), grey elsewhere; a crop to the
     * left half draws about half the points. */
    char in[512];
    tmp_path(in, sizeof in, "pv_label.ply");
    CHECK(write_scene(in, 100, 1.0, 1, RGB8) == 10000);
    wpd_preview_options opt;
    wpd_preview_defaults(&opt);
    opt.width = 300;
    opt.height = 200;
    opt.label = "green"; /* 60 everywhere: every point labelled */
    wpd_preview_image img;
    wpd_preview_summary s;
    wpd_error err = {0};
    const char *paths[1] = {in};
    CHECK_MSG(wpd_preview_render(paths, 1, &opt, &img, &s, &err) == 0, "%s", err.msg);
    CHECK(s.panel[0].labelled == s.panel[0].drawn && !strcmp(s.label, "green"));
    int red = 0, grey = 0;
    for (size_t i = 0; img.rgb && i < (size_t)img.width * img.height; i++) {
        const uint8_t *p = img.rgb + 3 * i;
        red |= p[0] > 100 && p[1] < 40 && p[2] < 40;
        grey |= p[0] == p[1] && p[1] == p[2] && p[0] < 200;
    }
    CHECK_MSG(red && !grey, "red %d grey %d", red, grey);
    wpd_preview_image_free(&img);
    opt.label = "blue";  /* 0 at x = 0 only */
    opt.crop = 1;
    opt.crop_lo[0] = 512000, opt.crop_lo[1] = 4300000;
    opt.crop_hi[0] = 512050, opt.crop_hi[1] = 4300100;
    CHECK_MSG(wpd_preview_render(paths, 1, &opt, &img, &s, &err) == 0, "%s", err.msg);
    CHECK_MSG(s.panel[0].points == 5000, "%llu points in the crop",
              (unsigned long long)s.panel[0].points);
    CHECK(s.panel[0].labelled == s.panel[0].drawn - 100); /* the column x = 0 */
    wpd_preview_image_free(&img);
    opt.label = "nothing";
    CHECK(wpd_preview_render(paths, 1, &opt, &img, &s, &err) == -1 && err.code == WPD_E_USAGE);
    wpd_preview_image_free(&img);
}
