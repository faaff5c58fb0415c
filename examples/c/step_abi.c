/*
 * mfcbeam's own compensator (or, with -DMODEL, its model W) as a C caller
 * sees it, behind the step ABI (include/mfcbeam_candidate.h), so that
 * `mfcbeam bench` times libmfcbeam beside other C libraries and FMUs, and
 * `mfcbeam conform --library` checks it:
 *
 *     cc -O2 -shared -fPIC -I include -o mfcbeam_step.so examples/c/step_abi.c \
 *        target/release/libmfcbeam.a -lpthread -ldl -lm
 *
 * `create` reads the model file into memory and builds a heap handle from
 * it (mfcbeam_compensator_from_json); it refuses (NULL) without a file: its
 * model is not compiled in. One sample is one mfcbeam_compensator_compensate.
 */
#include <stdio.h>
#include <stdlib.h>

#include "mfcbeam.h"
#include "mfcbeam_candidate.h"

typedef struct {
#ifdef MODEL
    MfcbeamModelHandle *model;
#else
    MfcbeamCompensatorHandle *compensator;
    int saturated;
#endif
} candidate;

/* The whole file as a NUL-terminated string, or NULL. */
static char *read_all(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t size = 0, room = 4096;
    char *text = malloc(room);
    size_t n;
    while (text && (n = fread(text + size, 1, room - size - 1, f)) > 0) {
        size += n;
        if (room - size - 1 == 0) {
            char *more = realloc(text, room *= 2);
            if (!more) { free(text); text = NULL; }
            else text = more;
        }
    }
    fclose(f);
    if (text) text[size] = '\0';
    return text;
}

void *mfcbeam_candidate_create(const char *model_file, double lower_limit, double upper_limit) {
    if (!model_file) return NULL;
    char *json = read_all(model_file);
    if (!json) return NULL;
    candidate *c = malloc(sizeof *c);
    char err[256];
    if (c) {
#ifdef MODEL
        (void)lower_limit; (void)upper_limit;
        c->model = mfcbeam_model_from_json(json, err, sizeof err);
        if (!c->model) { free(c); c = NULL; }
#else
        c->compensator = mfcbeam_compensator_from_json(json, lower_limit, upper_limit, err, sizeof err);
        c->saturated = 0;
        if (!c->compensator) { free(c); c = NULL; }
#endif
    }
    free(json);
    return c;
}

double mfcbeam_candidate_step(void *p, double input) {
    candidate *c = p;
#ifdef MODEL
    return mfcbeam_model_step(c->model, input);
#else
    int flags = 0;
    double u = mfcbeam_compensator_compensate(c->compensator, input, &flags);
    c->saturated = (flags & MFCBEAM_FLAG_SATURATED) != 0;
    return u;
#endif
}

#ifndef MODEL
int mfcbeam_candidate_saturated(const void *p) { return ((const candidate *)p)->saturated; }
#endif

void mfcbeam_candidate_free(void *p) {
    candidate *c = p;
#ifdef MODEL
    mfcbeam_model_free(c->model);
#else
    mfcbeam_compensator_free(c->compensator);
#endif
    free(c);
}
