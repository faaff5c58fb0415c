/* A hostile step library (the step ABI of mfcbeam bench and conform
 * --library): the identity u = y_d until its HOSTILE behaviour starts at
 * step number TRIGGER (the modes of hostile_fmu.c: 1 null dereference,
 * 2 hang, 3 abort, 4 exit(0), 5 allocation without end at create,
 * 6 wrong answer, 7 slow).
 */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef HOSTILE
#define HOSTILE 0
#endif
#ifndef TRIGGER
#define TRIGGER 0
#endif

static long steps;

void *mfcbeam_candidate_create(const char *model_file, double lower, double upper) {
    (void)model_file; (void)lower; (void)upper;
    if (HOSTILE == 5) {
        size_t n = (size_t)8 << 30;
        char *p = malloc(n);
        if (p) memset(p, 1, n);
        else { volatile int *z = 0; *z = 1; }
    }
    return calloc(1, sizeof(double));
}

double mfcbeam_candidate_step(void *c, double x) {
    (void)c;
    if (steps++ >= TRIGGER) {
        switch (HOSTILE) {
        case 1: { volatile int *z = 0; *z = 1; break; }
        case 2: for (;;) pause();
        case 3: abort();
        case 4: exit(0);
        case 6: return 2.0 * x;
        default: break;
        }
    }
    return x;
}

void mfcbeam_candidate_free(void *c) { free(c); }
