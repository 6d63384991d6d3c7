/* test_collection.c - a collection's state (resample/collection.h): what
 * wpd writes it reads back exactly, and every cut or changed byte that
 * makes it something else fails with one message and nothing loaded. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "resample/collection.h"

/* A state of two inputs (names with bytes json.h escapes), one output
 * each, a pending rename, an empty box, class lists. */
static void sample_state(wpd_collection *c)
{
    memset(c, 0, sizeof *c);
    snprintf(c->wpd_version, sizeof c->wpd_version, "0.2.0");
    c->radius = 0.76914416441779376, c->factor = 0.92748989831712625, c->nights = 2;
    c->opt = (wpd_coll_options){0.68, 0.05, WPD_RADIUS_MULTISCALE, 13, 5, 4, 1, 0,
                                18446744073709551615ull, strdup("7,18"), strdup(""),
                                strdup("cls \"x\"")};
    c->noutputs = c->ninputs = 2, c->npending = 1;
    c->outputs = calloc(2, sizeof *c->outputs);
    c->inputs = calloc(2, sizeof *c->inputs);
    c->pending = calloc(1, sizeof *c->pending);
    const char *names[2] = {"a.las", "b\xc3\xa9\t.las"};
    for (int i = 0; i < 2; i++) {
        c->outputs[i] = (wpd_coll_output){strdup(names[i]), 1000u + (unsigned)i};
        wpd_coll_input *e = &c->inputs[i];
        e->name = strdup(names[i]), e->output = strdup(names[i]);
        e->size = 3141385, e->mtime_ns = -5 + i, e->points = (uint64_t)(9411 * i);
        e->night = i + 1;
        for (int a = 0; a < 3; a++) {
            e->bounds[a] = 500000 + a + 0.1, e->bounds[3 + a] = 500091.28 + a;
            e->out_bounds[a] = i ? 500000.5 : INFINITY;
            e->out_bounds[3 + a] = i ? 500090.5 : -INFINITY;
        }
    }
    c->pending[0] = (wpd_coll_rename){strdup(".b\xc3\xa9\t.las.wpd-tmp-vm-1-abcdef"),
                                      strdup(names[1])};
}

TEST(collection_state_reads_back_what_it_writes)
{
    wpd_collection c, d = {0};
    sample_state(&c);
    char *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    wpd_error err = {0};
    CHECK(wpd_collection_format(&c, &a, &na) == 0);
    CHECK_MSG(wpd_collection_parse(&d, a, na, "s", &err) == 0, "%s", err.msg);
    CHECK(wpd_collection_format(&d, &b, &nb) == 0);
    CHECK_MSG(na == nb && memcmp(a, b, na) == 0, "%s\n---\n%s", a, b);
    CHECK(d.exists && d.ninputs == 2 && d.npending == 1 && d.opt.seed == c.opt.seed);
    CHECK(!strcmp(d.inputs[1].name, "b\xc3\xa9\t.las") && d.inputs[0].mtime_ns == -5);
    CHECK(isinf(d.inputs[0].out_bounds[0]) && d.inputs[0].out_bounds[0] > 0);
    CHECK(wpd_collection_find(&d, "a.las") == &d.inputs[0]);
    CHECK(wpd_collection_find(&d, "c.las") == NULL);
    /* every prefix of it fails, with a message */
    int cut_failed = 0;
    for (size_t n = 0; n + 2 < na; n += 7) {
        wpd_collection e = {0};
        wpd_error ee = {0};
        cut_failed += wpd_collection_parse(&e, a, n, "s", &ee) != 0 && ee.msg[0] && !e.exists;
        wpd_collection_free(&e);
    }
    CHECK_MSG(cut_failed == (int)((na - 3) / 7 + 1), "%d cut states parsed", cut_failed);
    free(a), free(b);
    wpd_collection_free(&c);
    wpd_collection_free(&d);
}

/* text with the first occurrence of from replaced by to, parsed. */
static int parse_changed(const char *text, const char *from, const char *to, char *msg,
                         size_t size)
{
    const char *at = strstr(text, from);
    if (!at)
        return 99;
    size_t n = strlen(text) + strlen(to) + 1;
    char *t = malloc(n);
    snprintf(t, n, "%.*s%s%s", (int)(at - text), text, to, at + strlen(from));
    wpd_collection c = {0};
    wpd_error err = {0};
    int rc = wpd_collection_parse(&c, t, strlen(t), "s", &err);
    snprintf(msg, size, "%s", err.msg);
    wpd_collection_free(&c);
    free(t);
    return rc;
}

TEST(collection_state_refuses_what_it_would_not_write)
{
    wpd_collection c;
    sample_state(&c);
    char *a = NULL, msg[512];
    size_t na = 0;
    CHECK(wpd_collection_format(&c, &a, &na) == 0);
    static const char *const bad[][2] = {
        {"\"version\": 1", "\"version\": 2"},            /* another format version */
        {"\"radius\"", "\"radiu\""},                      /* another key */
        {"\"output\": \"a.las\"", "\"output\": \"../a.las\""}, /* not a name in the folder */
        {"\"output\": \"a.las\"", "\"output\": \"z.las\""}, /* an output not listed */
        {"\"to\": \"b", "\"to\": \"a"},                   /* a rename to an unlisted name */
        {".wpd-tmp-", ".wpd-tnp-"},                       /* a rename from no temporary */
        {"\"night\": 2", "\"night\": 3"},                 /* a night after "nights" */
        {"\"density_factor\": 0.9", "\"density_factor\": 1.9"},
        {"\"k\": 13", "\"k\": 65"},
        {"\"seed\": 18446744073709551615", "\"seed\": 18446744073709551616"},
        {"\"name\": \"b", "\"name\": \"a.las\", \"x\": \"b"},
        {"\\u00c3", "\\u0000"},                           /* a NUL in a name */
        {"\\u00c3", "\\u00C3"},                           /* not as json.h writes it */
        {"\\u00c3", "\\u01c3"},
        {"}\n", "} x\n"},                                 /* more after the end */
        {"\"bounds\": [", "\"bounds\": [nan"},
        {"\"mtime_ns\": -5", "\"mtime_ns\": --5"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        int rc = parse_changed(a, bad[i][0], bad[i][1], msg, sizeof msg);
        CHECK_MSG(rc == -1 && !strncmp(msg, "s: ", 3), "%s -> %s: rc %d, '%s'", bad[i][0],
                  bad[i][1], rc, msg);
    }
    CHECK(parse_changed(a, "\"version\": 1", "\"version\": 2", msg, sizeof msg) == -1 &&
          strstr(msg, "format version 2"));
    CHECK(parse_changed(a, "\"k\": 13", "\"k\"  :\n\t13", msg, sizeof msg) == 0); /* spaces */
    free(a);
    wpd_collection_free(&c);
}
