/* preview_png.c - `wpd preview`'s PNG encoding through libpng into a
 * memory buffer: a palette PNG when the picture has at most 256 colours
 * (height colouring), else 8-bit RGB; tEXt chunks, no time chunk.
 */
#include "tools/preview/preview_internal.h"

#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct png_sink {
    uint8_t *data;
    size_t len, cap;
    char msg[200];
} png_sink;

static void sink_write(png_structp png, png_bytep data, png_size_t len)
{
    png_sink *s = png_get_io_ptr(png);
    if (s->len + len > s->cap) {
        size_t cap = s->cap ? s->cap : 1 << 16;
        while (cap < s->len + len)
            cap *= 2;
        uint8_t *grown = realloc(s->data, cap);
        if (!grown)
            png_error(png, "out of memory");
        s->data = grown;
        s->cap = cap;
    }
    memcpy(s->data + s->len, data, len);
    s->len += len;
}

static void sink_flush(png_structp png) { (void)png; }

static void sink_error(png_structp png, png_const_charp msg)
{
    png_sink *s = png_get_error_ptr(png);
    snprintf(s->msg, sizeof s->msg, "%s", msg);
    png_longjmp(png, 1);
}

static void sink_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* warnings do not change the output */
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* The image's distinct colours (0xRRGGBB, ascending) when there are at most
 * 256 of them: returns how many, or 0 when there are more (or no memory:
 * the caller then simply writes RGB). */
static int find_palette(const wpd_preview_image *img, uint32_t pal[256])
{
    uint8_t *seen = calloc((size_t)1 << 21, 1); /* one bit per 24-bit colour */
    if (!seen)
        return 0;
    int n = 0;
    size_t npix = (size_t)img->width * img->height;
    for (size_t i = 0; i < npix && n <= 256; i++) {
        const uint8_t *p = img->rgb + 3 * i;
        uint32_t c = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
        if (seen[c >> 3] & (1u << (c & 7)))
            continue;
        seen[c >> 3] |= (uint8_t)(1u << (c & 7));
        if (n < 256)
            pal[n] = c;
        n++;
    }
    free(seen);
    if (n > 256)
        return 0;
    qsort(pal, (size_t)n, sizeof *pal, cmp_u32);
    return n;
}

/* Palette indices of the image's pixels (every colour is in pal). */
static void index_pixels(const wpd_preview_image *img, const uint32_t *pal, int n, uint8_t *out)
{
    size_t npix = (size_t)img->width * img->height;
    for (size_t i = 0; i < npix; i++) {
        const uint8_t *p = img->rgb + 3 * i;
        uint32_t c = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
        int lo = 0, hi = n - 1;
        while (lo < hi) {
            int mid = (lo + hi) / 2;
            if (pal[mid] < c)
                lo = mid + 1;
            else
                hi = mid;
        }
        out[i] = (uint8_t)lo;
    }
}

/* libpng's part: writes rows (palette indices when npal > 0, else RGB) into
 * the sink. All state is set before setjmp, so a longjmp clobbers nothing.
 * Returns 0, or -1 with sink->msg set. */
static int png_encode_rows(png_sink *sink, png_bytep *rows, int w, int h, const png_color *plte,
                           int npal, png_text *text, int ntext)
{
    png_structp ps = png_create_write_struct(PNG_LIBPNG_VER_STRING, sink, sink_error, sink_warning);
    png_infop info = ps ? png_create_info_struct(ps) : NULL;
    if (!info) {
        png_destroy_write_struct(ps ? &ps : NULL, NULL);
        snprintf(sink->msg, sizeof sink->msg, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(ps))) {
        png_destroy_write_struct(&ps, &info);
        return -1;
    }
    png_set_write_fn(ps, sink, sink_write, sink_flush);
    png_set_compression_level(ps, 9);
    png_set_IHDR(ps, info, (png_uint_32)w, (png_uint_32)h, 8,
                 npal ? PNG_COLOR_TYPE_PALETTE : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (npal) {
        png_set_PLTE(ps, info, plte, npal);
        png_set_filter(ps, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE); /* indices: no prediction */
    }
    if (ntext > 0)
        png_set_text(ps, info, text, ntext);
    png_set_rows(ps, info, rows);
    png_write_png(ps, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&ps, &info);
    return 0;
}

int wpd_preview_encode_png(const wpd_preview_image *img, const char *const *keys,
                           const char *const *texts, int ntext, const char *name,
                           uint8_t **png, size_t *len, wpd_error *err)
{
    *png = NULL;
    *len = 0;
    png_sink sink;
    memset(&sink, 0, sizeof sink);
    uint32_t pal[256];
    int npal = find_palette(img, pal);
    size_t npix = (size_t)img->width * img->height;
    uint8_t *indexed = npal ? malloc(npix) : NULL;
    if (!indexed)
        npal = 0;
    png_bytep *rows = malloc((size_t)img->height * sizeof *rows);
    png_text *text = calloc((size_t)(ntext > 0 ? ntext : 1), sizeof *text);
    png_color plte[256];
    int rc = -1;
    if (!rows || !text) {
        snprintf(sink.msg, sizeof sink.msg, "out of memory");
        goto done;
    }
    if (npal) {
        index_pixels(img, pal, npal, indexed);
        for (int i = 0; i < npal; i++) {
            plte[i].red = (png_byte)(pal[i] >> 16);
            plte[i].green = (png_byte)(pal[i] >> 8);
            plte[i].blue = (png_byte)pal[i];
        }
    }
    for (int y = 0; y < img->height; y++)
        rows[y] = npal ? indexed + (size_t)y * img->width : img->rgb + (size_t)y * img->width * 3;
    for (int i = 0; i < ntext; i++) {
        text[i].compression = PNG_TEXT_COMPRESSION_NONE;
        text[i].key = (char *)keys[i];
        text[i].text = (char *)texts[i];
    }
    rc = png_encode_rows(&sink, rows, img->width, img->height, plte, npal, text, ntext);
done:
    free(rows);
    free(text);
    free(indexed);
    if (rc) {
        free(sink.data);
        if (!strcmp(sink.msg, "out of memory"))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory encoding the PNG", name);
        return wpd_fail(err, WPD_E_IO, "%s: PNG encoding failed: %s", name, sink.msg);
    }
    *png = sink.data;
    *len = sink.len;
    return 0;
}
