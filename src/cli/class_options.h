/* class_options.h - the command line's class options of `wpd resample`
 * (--drop-class, --keep-class, --class-count, --class-field) turned into
 * the wpd_class_options of resample/classes.h. */
#ifndef WPD_CLASS_OPTIONS_H
#define WPD_CLASS_OPTIONS_H

#include <stdint.h>

#include "common/error.h"
#include "io/cloud.h"
#include "resample/classes.h"

typedef struct wpd_class_args {
    uint8_t *drop, *keep;          /* [WPD_CLASS_MAX + 1], or NULL: none named */
    wpd_class_request *counts;
    int ncounts;
    const char *field;             /* --class-field, or NULL */
} wpd_class_args;

/* Adds the classes of a list "2,6,9-12" (numbers in 0..WPD_CLASS_MAX, ranges
 * lo-hi with lo <= hi) to *set, allocating it on first use. Returns 0, or
 * -1 with err set (WPD_E_USAGE naming the bad item; WPD_E_MEMORY). */
int wpd_class_list_parse(const char *text, uint8_t **set, wpd_error *err);

/* Adds "CLASS=N" (N > 0, a number with an optional k or M suffix) to
 * a->counts. Returns 0, or -1 with err set (WPD_E_USAGE; WPD_E_MEMORY). */
int wpd_class_count_parse(const char *text, wpd_class_args *a, wpd_error *err);

/* 1 when any class option other than --class-field was given. */
int wpd_class_args_used(const wpd_class_args *a);

/* Checks that no class is named twice (dropped and kept, counted twice,
 * counted and dropped ...). Returns 0, or -1 with err set (WPD_E_USAGE). */
int wpd_class_args_check(const wpd_class_args *a, wpd_error *err);

/* The class options for cloud: the class field is --class-field, else the
 * field "classification" (LAS: its class bits); it must be an integer field
 * of the inputs. Returns 0, or -1 with err set (WPD_E_USAGE). */
int wpd_class_args_resolve(const wpd_class_args *a, const wpd_cloud *cloud,
                           wpd_class_options *out, wpd_error *err);

void wpd_class_args_free(wpd_class_args *a);

/* The summary lines of a run by class: points in and out per class, and
 * the radius of each resampled group (stdout). */
void wpd_class_print_summary(const wpd_class_result *c);

#endif
