/* fuzz_collection.c - libFuzzer target for the parser of a collection's
 * state (src/resample/collection_parse.c, docs/ingest.md). Built by `make
 * fuzz` / `make fuzz-smoke`.
 *
 * The input is a state file. It must parse or fail with an error message,
 * never crash or read past its bytes (ASan). A state that parses is
 * written back (wpd_collection_format) and parsed again: that must succeed
 * and give the same text - what wpd writes it reads, exactly. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "resample/collection.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* An exactly sized copy: ASan sees any read past the text. */
    char *text = malloc(size ? size : 1);
    if (!text)
        return 0;
    memcpy(text, data, size);
    wpd_collection c = {0}, d = {0};
    wpd_error err = {0};
    if (wpd_collection_parse(&c, text, size, "state", &err) == 0) {
        char *a = NULL, *b = NULL;
        size_t na = 0, nb = 0;
        if (wpd_collection_format(&c, &a, &na) ||
            wpd_collection_parse(&d, a, na, "state again", &err) ||
            wpd_collection_format(&d, &b, &nb) || na != nb || memcmp(a, b, na)) {
            fprintf(stderr, "fuzz_collection: a state that parsed does not round-trip: %s\n",
                    err.msg);
            abort();
        }
        free(a), free(b);
    } else if (!err.msg[0]) {
        fprintf(stderr, "fuzz_collection: a failure without a message\n");
        abort();
    }
    wpd_collection_free(&c);
    wpd_collection_free(&d);
    free(text);
    return 0;
}
