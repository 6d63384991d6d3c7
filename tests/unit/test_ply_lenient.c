/* test_ply_lenient.c - PLY files that bend the specification: the harmless
 * ways are read with one warning per kind (naming the file and the line)
 * and give the file's points; the ways that could give wrong points are
 * refused with one message naming the file and the line or field. Every
 * file is made here (docs/formats.md, PLY, lists the cases). */
#include "harness.h"
#include "ply_files.h"

#include "io/reader.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ helpers */

/* The coordinates every lenient file below holds, in order. */
static const double want_xyz[3][3] = {{1, 2, 3}, {4.5, 5, 6}, {7, 8, 9.25}};

/* Writes text (len bytes, or strlen when 0) to <tmp>/name; path gets the
 * file's path. */
static void write_case(char *path, size_t size, const char *name, const char *text, size_t len)
{
    cf_tmp_path(path, size, name);
    cf_write_file(path, text, len ? len : strlen(text));
}

/* Counts the warnings of path's header that start with the path and contain
 * want (NULL: every warning); *total gets all of them. */
static uint32_t warnings_with(const wpd_header *h, const char *path, const char *want,
                              uint32_t *total)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < h->warnings.n; i++) {
        const char *line = h->warnings.line[i];
        if (!strncmp(line, path, strlen(path)) && (!want || strstr(line, want)))
            n++;
    }
    *total = h->warnings.n + h->warnings.unstored;
    return n;
}

/* The three points of want_xyz as ascii vertex lines with normals, one per
 * line (the Blender 2.4x exporter ends each with a blank). */
static const char ascii_vertices[] = "1.000000 2.000000 3.000000 0.000000 0.000000 1.000000 \n"
                                     "4.5 5 6 0 0 1 \n"
                                     "7 8 9.25 0 1 0 \n";

/* A header with x y z of type ty and the lines extra inserted after the
 * format line; fmt is the format line. */
static void header(char *out, size_t size, const char *fmt, const char *extra, const char *ty,
                   const char *end)
{
    snprintf(out, size,
             "ply\n%s\n%selement vertex 3\nproperty %s x\nproperty %s y\nproperty %s z\n"
             "property %s nx\nproperty %s ny\nproperty %s nz\n%s",
             fmt, extra, ty, ty, ty, ty, ty, ty, end);
}

/* Writes <tmp>/name: header(fmt, extra, ty, end) then body; path gets the
 * file's path. */
static void write_ascii_case(char *path, size_t size, const char *name, const char *fmt,
                             const char *extra, const char *ty, const char *end, const char *body)
{
    char hdr[1024], text[4096];
    header(hdr, sizeof hdr, fmt, extra, ty, end);
    snprintf(text, sizeof text, "%s%s", hdr, body);
    write_case(path, size, name, text, 0);
}

/* Opens path; NULL, and a failed check, when it does not open. */
static wpd_reader *open_checked(const char *path, int *failures_)
{
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r != NULL, "%s", err.msg);
    return r;
}

/* Opens path, expects exactly one warning, containing want (or none when
 * want is NULL), and npts points equal to the first npts of want_xyz. */
static void check_lenient(const char *path, const char *want, size_t npts, int *failures_)
{
    wpd_reader *r = open_checked(path, failures_);
    if (!r)
        return;
    wpd_error err;
    uint32_t total;
    uint32_t hits = warnings_with(wpd_reader_header(r), path, want, &total);
    const char *first = total ? wpd_reader_header(r)->warnings.line[0] : "(none)";
    CHECK_MSG(want ? hits == 1 && total == 1 : total == 0, "%s: want '%s', got %u: %s", path,
              want ? want : "no warning", total, first);
    cf_cloud c;
    CHECK_MSG(cf_read_all(r, &c, 2, &err) == 0, "%s", err.msg);
    CHECK_MSG(c.n == npts, "%s: %zu points", path, c.n);
    for (size_t i = 0; i < c.n && i < npts; i++)
        CHECK_MSG(!memcmp(c.xyz + 3 * i, want_xyz[i], sizeof want_xyz[i]),
                  "%s: point %zu is %g %g %g", path, i, c.xyz[3 * i], c.xyz[3 * i + 1],
                  c.xyz[3 * i + 2]);
    cf_cloud_free(&c);
    wpd_reader_close(r);
}

/* Binary vertices of want_xyz with normals as float32, little- or big-endian. */
static size_t binary_vertices(uint8_t *out, int big_endian)
{
    size_t n = 0;
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 6; k++) {
            float v = k < 3 ? (float)want_xyz[i][k] : (k == 5 ? 1.0f : 0.0f);
            uint8_t b[4];
            memcpy(b, &v, 4);
            for (int j = 0; j < 4; j++)
                out[n++] = big_endian ? b[3 - j] : b[j];
        }
    return n;
}

/* ------------------------------------------------------------------ lenient */

/* Blender 2.4x's PLY exporter wrote a free-text line after the format line
 * (issue 14), float32/uint8/int32 type names and a face element. */
static const char blender_line[] =
    "Created by Blender3D 247 - www.blender.org, source file: 'cube.blend'\n";
static const char blender_faces[] =
    "element face 1\nproperty list uint8 int32 vertex_indices\nend_header\n";

TEST(ply_lenient_blender_247_ascii)
{
    char body[256], path[512];
    snprintf(body, sizeof body, "%s3 0 1 2 \n", ascii_vertices);
    write_ascii_case(path, sizeof path, "blender247_ascii.ply", "format ascii 1.0", blender_line,
                     "float32", blender_faces, body);
    check_lenient(path, "PLY header line 3 is not a keyword line (skipped): 'Created by Blender3D",
                  3, failures_);
}

TEST(ply_lenient_blender_247_binary)
{
    for (int be = 0; be < 2; be++) {
        uint8_t file[2048];
        char hdr[1024], path[512], name[64];
        header(hdr, sizeof hdr,
               be ? "format binary_big_endian 1.0" : "format binary_little_endian 1.0",
               blender_line, "float32", blender_faces);
        size_t n = strlen(hdr);
        memcpy(file, hdr, n);
        n += binary_vertices(file + n, be);
        static const uint8_t face_le[] = {3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0};
        static const uint8_t face_be[] = {3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 2};
        memcpy(file + n, be ? face_be : face_le, sizeof face_le);
        n += sizeof face_le;
        snprintf(name, sizeof name, "blender247_binary_%d.ply", be);
        write_case(path, sizeof path, name, (const char *)file, n);
        check_lenient(path, "PLY header line 3 is not a keyword line", 3, failures_);
    }
}

/* Several kinds at once: one warning per kind, the first line and a count. */
TEST(ply_lenient_one_warning_per_kind)
{
    char path[512];
    write_ascii_case(path, sizeof path, "kinds.ply", "format ascii 1.0",
                     "Created by hand\n\nmade on a Sunday\n\nformat ascii 1.0\n", "float",
                     "end_header\n", ascii_vertices);
    wpd_reader *r = open_checked(path, failures_);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    uint32_t total;
    CHECK(warnings_with(h, path, "line 3 is not a keyword line (skipped): 'Created by hand' "
                        "(and 1 more such line)", &total) == 1);
    CHECK(warnings_with(h, path, "line 4 is blank (skipped) (and 1 more such line)", &total) == 1);
    CHECK(warnings_with(h, path, "line 7 repeats the format line", &total) == 1);
    CHECK_MSG(total == 3, "%u warnings", total);
    wpd_reader_close(r);
}

TEST(ply_lenient_blank_header_line)
{
    char path[512];
    write_ascii_case(path, sizeof path, "blank.ply", "format ascii 1.0", "\n  \t\n", "float",
                     "end_header\n", ascii_vertices);
    check_lenient(path, "PLY header line 3 is blank (skipped) (and 1 more such line)", 3,
                  failures_);
}

/* Blanks after end_header: the data still starts after the line end, which
 * matters for binary files. CR before LF is a line end, not an oddity. */
TEST(ply_lenient_end_header_blanks)
{
    static const char *const ends[] = {"end_header \n", "end_header\t \r\n", "end_header\r\n"};
    for (int e = 0; e < 3; e++)
        for (int binary = 0; binary < 2; binary++) {
            uint8_t file[2048];
            char hdr[1024], path[512], name[64];
            header(hdr, sizeof hdr,
                   binary ? "format binary_little_endian 1.0" : "format ascii 1.0", "",
                   "float", ends[e]);
            size_t n = strlen(hdr);
            memcpy(file, hdr, n);
            if (binary)
                n += binary_vertices(file + n, 0);
            else {
                memcpy(file + n, ascii_vertices, sizeof ascii_vertices - 1);
                n += sizeof ascii_vertices - 1;
            }
            snprintf(name, sizeof name, "end_blanks_%d_%d.ply", e, binary);
            write_case(path, sizeof path, name, (const char *)file, n);
            check_lenient(path, e < 2 ? "PLY header line 10 has blanks after end_header" : NULL,
                          3, failures_);
        }
}

TEST(ply_lenient_version_written_otherwise)
{
    static const char *const versions[] = {"1", "1.00", "1.0e0"};
    for (int i = 0; i < 3; i++) {
        char path[512], fmt[64], want[128], name[64];
        snprintf(fmt, sizeof fmt, "format ascii %s", versions[i]);
        snprintf(name, sizeof name, "version_%d.ply", i);
        write_ascii_case(path, sizeof path, name, fmt, "", "float", "end_header\n",
                         ascii_vertices);
        snprintf(want, sizeof want, "line 2 writes version 1.0 in another way (read as 1.0): '%s'",
                 versions[i]);
        check_lenient(path, want, 3, failures_);
    }
}

/* Binary files whose elements end where the header says: bytes after them,
 * or a file cut inside an element after the vertices (points complete). */
TEST(ply_lenient_binary_tail)
{
    static const char edges[] = "element edge 2\nproperty int a\nproperty int b\nend_header\n";
    static const char edges_cams[] = "element edge 2\nproperty int a\nproperty int b\n"
                                     "element cam 1\nproperty double t\nend_header\n";
    for (int c = 0; c < 4; c++) {
        uint8_t file[2048] = {0};
        char hdr[1024], path[512], name[64];
        header(hdr, sizeof hdr, "format binary_little_endian 1.0", "", "float",
               c == 0 ? "end_header\n" : c == 3 ? edges_cams : edges);
        size_t n = strlen(hdr);
        memcpy(file, hdr, n);
        n += binary_vertices(file + n, 0);
        /* trailing, trailing, short, short in the element before the last */
        size_t tail = c == 0 ? 5 : c == 1 ? 16 + 7 : c == 2 ? 16 - 6 : 16 - 3;
        snprintf(name, sizeof name, "tail_%d.ply", c);
        write_case(path, sizeof path, name, (const char *)file, n + tail);
        static const char *const want[] = {
            "5 bytes after the last PLY element (which ends at offset ",
            "7 bytes after the last PLY element",
            "file ends 6 bytes short of the end of PLY element 'edge'; the vertices are complete",
            "file ends 3 bytes short of the end of PLY element 'edge'"};
        check_lenient(path, want[c], 3, failures_);
    }
}

/* Harmless, and so read without a warning: comment and obj_info in their
 * variants, blank lines between ascii items, a vertex count of 0, the type
 * names of both naming styles. */
TEST(ply_lenient_quiet_cases)
{
    char path[512];
    write_ascii_case(path, sizeof path, "quiet.ply", "format ascii 1.0",
                     "comment\ncomment\tby tab\nobj_info\nobj_info  two blanks\n", "float",
                     "end_header\n",
                     "\n1 2 3 0 0 1\n\n \t\n4.5 5 6 0 0 1\r\n7 8 9.25 0 1 0\n\n\n");
    check_lenient(path, NULL, 3, failures_);
    wpd_reader *r = open_checked(path, failures_);
    if (r) {
        const wpd_ply_info *ply = &wpd_reader_header(r)->ply;
        CHECK(ply->ncomments == 2 && !strcmp(ply->comments[0], "") &&
              !strcmp(ply->comments[1], "by tab"));
        CHECK(ply->nobj_info == 2 && !strcmp(ply->obj_info[1], " two blanks"));
        wpd_reader_close(r);
    }
    static const char *const types[] = {"double", "float64", "float"};
    for (int t = 0; t < 3; t++) {
        char name[64];
        snprintf(name, sizeof name, "types_%d.ply", t);
        write_ascii_case(path, sizeof path, name, "format ascii 1.0", "", types[t],
                         "end_header\n", ascii_vertices);
        check_lenient(path, NULL, 3, failures_);
    }
    write_case(path, sizeof path, "zero.ply",
               "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
               "element face 1\nproperty list uchar int vertex_indices\nend_header\n0\n", 0);
    check_lenient(path, NULL, 0, failures_);
}

/* "commentfoo" is not the comment keyword: skipped as a stray line. */
TEST(ply_lenient_comment_without_blank)
{
    char path[512];
    write_ascii_case(path, sizeof path, "commentfoo.ply", "format ascii 1.0", "commentfoo bar\n",
                     "float", "end_header\n", ascii_vertices);
    check_lenient(path, "line 3 is not a keyword line (skipped): 'commentfoo bar'", 3, failures_);
}

/* ------------------------------------------------------------------ strict */

/* Writes an ascii case (see write_ascii_case, float x y z nx ny nz) and
 * expects it refused with one line naming the file and containing want. */
static void check_refused(const char *name, const char *fmt, const char *extra,
                          const char *body, const char *want, int *failures_)
{
    char path[512], msg[WPD_ERRMSG_MAX];
    write_ascii_case(path, sizeof path, name, fmt, extra, "float", "end_header\n", body);
    CHECK_MSG(pf_fails_with(path, want, msg, sizeof msg), "%s: got '%s'", name, msg);
    CHECK_MSG(!strchr(msg, '\n'), "%s: not one line", name);
}

TEST(ply_strict_header_cases)
{
    static const struct { const char *extra, *fmt, *want; } cases[] = {
        {"1 2 3\n", "format ascii 1.0", "line 3: a number where a keyword belongs"},
        {"-0.5 2\n", "format ascii 1.0", "line 3: a number where a keyword belongs"},
        {"element face 1\nproprety float z\n", "format ascii 1.0",
         "line 4: unknown keyword on a line shaped like a declaration 'proprety'"},
        {"elment face 1\n", "format ascii 1.0", "line 3: unknown keyword on a line shaped"},
        {"element face 1\npropery list uchar int vertex_indices\n", "format ascii 1.0",
         "line 4: unknown keyword on a line shaped like a declaration 'propery'"},
        {"", "format ascii 1.1", "line 2: unsupported PLY version '1.1'"},
        {"", "format ascii 2.0", "line 2: unsupported PLY version '2.0'"},
        {"format binary_little_endian 1.0\n", "format ascii 1.0",
         "line 3: second format line with another encoding 'binary_little_endian'"},
        {"element face 1\nproperty list uchar float16 idx\n", "format ascii 1.0",
         "line 4: unknown list item type 'float16'"},
        {"element face 1\nproperty half idx\n", "format ascii 1.0",
         "line 4: unknown property type 'half'"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char name[64];
        snprintf(name, sizeof name, "strict_hdr_%zu.ply", i);
        check_refused(name, cases[i].fmt, cases[i].extra, ascii_vertices, cases[i].want,
                      failures_);
    }
}

/* Ascii items that are not one line each would shift every value after
 * them: refused, naming the line. */
TEST(ply_strict_ascii_lines)
{
    static const struct { const char *body, *want; } cases[] = {
        {"1 2 3 0 0 1 9\n4.5 5 6 0 0 1\n7 8 9.25 0 1 0\n",
         "PLY line 11 holds more values than one item of element 'vertex' has"},
        {"1 2 3 0 0 1\n4.5 5 6 0 0 1\n7 8 9.25 0 1 0 5\n",
         "PLY line 13 holds more values than one item of element 'vertex' has"},
        {"1 2 3 0 0 1 4.5 5 6 0 0 1\n7 8 9.25 0 1 0\n",
         "PLY line 11 holds more values than one item of element 'vertex' has"},
        {"1 2 3\n0 0 1\n4.5 5 6 0 0 1\n7 8 9.25 0 1 0\n",
         "PLY line 11: element 'vertex' item 0 has fewer values than its 6 properties need "
         "(it goes on at line 12)"},
        {"1 2 3 0 0 1\n4.5 5 6 0 0\n1\n7 8 9.25 0 1 0\n",
         "PLY line 12: element 'vertex' item 1 has fewer values than its 6 properties need "
         "(it goes on at line 13)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char name[64];
        snprintf(name, sizeof name, "strict_lines_%zu.ply", i);
        check_refused(name, "format ascii 1.0", "", cases[i].body, cases[i].want, failures_);
    }
    /* The same rule for an element before the vertices, lists included. */
    char path[512], msg[WPD_ERRMSG_MAX];
    write_case(path, sizeof path, "strict_lines_face.ply",
               "ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int idx\n"
               "element vertex 1\nproperty float x\nproperty float y\nend_header\n"
               "3 0 1 2 7\n3 0 1 2\n1 2\n", 0);
    CHECK_MSG(pf_fails_with(path, "PLY line 9 holds more values than one item of element 'face'",
                            msg, sizeof msg), "got '%s'", msg);
    write_case(path, sizeof path, "strict_lines_list.ply",
               "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int idx\n"
               "element vertex 1\nproperty float x\nproperty float y\nend_header\n"
               "3 0 1\n2\n1 2\n", 0);
    CHECK_MSG(pf_fails_with(path, "PLY line 9: element 'face' item 0 has fewer values", msg,
                            sizeof msg), "got '%s'", msg);
}

/* Headers refused since before the leniency work (moved from test_ply.c). */
TEST(ply_header_errors)
{
    static const struct { const char *text, *want; } cases[] = {
        {"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n0123456789ab",
         "1000000000000"},
        {"ply\nformat binary_little_endian 1.0\nelement face 18446744073709551615\n"
         "property list uchar int idx\nelement vertex 1\nproperty float x\nproperty float y\n"
         "end_header\n01234567",
         "element 'face' count 18446744073709551615"},
        {"ply\nformat ascii 1.0\nelement vertex 100\nproperty float x\nproperty float y\n"
         "end_header\n1 2\n", "element 'vertex' count 100"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n1 2\n",
         "a number where a keyword belongs (no end_header line?) '1'"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n",
         "no end_header"},
        {"ply\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
         "no format line"},
        {"ply\nformat ascii 1.0\nelement face 0\nend_header\n", "no 'vertex' element"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\n"
         "end_header\n1 2\n", "no 'y' property"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n",
         "unknown property type 'flaot'"},
        {"ply\nformat ascii 2.0\nend_header\n", "unsupported PLY version"},
        {"ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format"},
        {"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "property before any element"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
         "property float x\nend_header\n1 2 3\n", "'x' appears twice"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty list uchar float y\n"
         "end_header\n1 1 2\n", "'y' is a list"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty list float uchar idx\n"
         "property float x\nproperty float y\nend_header\n", "not an integer type"},
        {"ply\nformat ascii 1.0\nelement vertex -5\nend_header\n", "bad element count"},
        {"plyx\nformat ascii 1.0\nend_header\n", "no 'ply' magic line"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty uchar y\n"
         "end_header\n1 2\n1 256\n", "vertex 1 property 'y': value '256' out of range for uchar"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty char y\n"
         "end_header\n1 2\n1 -129\n", "out of range for char"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty uint y\n"
         "end_header\n1 2\n1 -1\n", "out of range for uint"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
         "end_header\n1 2\n1 2x\n", "vertex 1 property 'y': '2x' is not a valid float"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty int y\n"
         "end_header\n1 2.5\n", "'2.5' is not a valid int"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char path[512], msg[WPD_ERRMSG_MAX];
        snprintf(path, sizeof path, "%s/hdr_err_%zu.ply", test_tmp_dir(), i);
        cf_write_file(path, cases[i].text, strlen(cases[i].text));
        CHECK_MSG(pf_fails_with(path, cases[i].want, msg, sizeof msg), "case %zu: got '%s'", i, msg);
    }
    /* A header longer than the limit. */
    size_t big = (1u << 20) + 100;
    char *text = malloc(big);
    memset(text, ' ', big);
    memcpy(text, "ply\nformat ascii 1.0\n", 21);
    for (size_t i = 100; i < big; i += 100)
        memcpy(text + i - 9, "\ncomment ", 9);
    char path[512], msg[WPD_ERRMSG_MAX];
    cf_tmp_path(path, sizeof path, "hdr_huge.ply");
    cf_write_file(path, text, big);
    free(text);
    CHECK_MSG(pf_fails_with(path, "no end_header line within", msg, sizeof msg), "got '%s'", msg);
}
