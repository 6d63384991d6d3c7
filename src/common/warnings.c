#include "common/warnings.h"

#include <stdarg.h>

void wpd_warn(wpd_warnings *w, const char *fmt, ...)
{
    if (w->n >= WPD_WARNINGS_MAX) {
        w->unstored++;
        return;
    }
    char *line = w->line[w->n++];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, WPD_ERRMSG_MAX, fmt, ap);
    va_end(ap);
    wpd_one_line(line);
}

void wpd_warnings_print(FILE *f, const char *command, const wpd_warnings *w)
{
    for (uint32_t i = 0; i < w->n; i++)
        fprintf(f, "wpd %s: warning: %s\n", command, w->line[i]);
    if (w->unstored)
        fprintf(f, "wpd %s: warning: %u more warnings about the same file not shown\n",
                command, w->unstored);
}
