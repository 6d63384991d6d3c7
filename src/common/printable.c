#include "common/printable.h"

#include <stdio.h>

char *wpd_printable(char *dst, size_t cap, const char *src)
{
    size_t n = 0;
    for (const unsigned char *p = (const unsigned char *)src; *p; p++) {
        char piece[5];
        int len;
        if (*p == '\\')
            len = snprintf(piece, sizeof piece, "\\\\");
        else if (*p < 0x20 || *p >= 0x7f)
            len = snprintf(piece, sizeof piece, "\\x%02x", *p);
        else
            len = snprintf(piece, sizeof piece, "%c", *p);
        if (n + (size_t)len >= cap)
            break;
        for (int i = 0; i < len; i++)
            dst[n++] = piece[i];
    }
    dst[n] = '\0';
    return dst;
}
