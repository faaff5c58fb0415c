/* A hostile FMU (FMI 2.0 Co-Simulation): the identity u = y_d (and
 * correction = 0 as a controller) until its HOSTILE behaviour starts at
 * doStep number TRIGGER (counted over every instance of the process):
 *
 *   1 a null dereference      2 a hang (after forking a child that sleeps)
 *   3 abort()                 4 exit(0)
 *   5 an allocation without end at instantiation (8 GB touched)
 *   6 a wrong answer (u = 2 y_d)
 *   7 slow: 20 us of spinning per step
 *
 * Built by verification/isolation.rs: cc -shared -fPIC -DHOSTILE=n
 * -DTRIGGER=k. Written against the standard's signatures, without its
 * headers: every type is a plain C type of the same ABI.
 */
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#ifndef HOSTILE
#define HOSTILE 0
#endif
#ifndef TRIGGER
#define TRIGGER 0
#endif

typedef struct {
    double y_d, u, reference, measurement, correction;
    int saturated;
} instance;

static long steps;

static double now_us(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e6 + t.tv_nsec / 1e3;
}

void *fmi2Instantiate(const char *name, int type, const char *guid, const char *resources,
                      const void *callbacks, int visible, int logging) {
    (void)name; (void)type; (void)guid; (void)resources; (void)callbacks;
    (void)visible; (void)logging;
    if (HOSTILE == 5) {
        size_t n = (size_t)8 << 30;
        char *p = malloc(n);
        if (p) memset(p, 1, n);
        else { volatile int *z = 0; *z = 1; }
    }
    return calloc(1, sizeof(instance));
}

void fmi2FreeInstance(void *c) { free(c); }
int fmi2SetupExperiment(void *c, int a, double b, double d, int e, double f) {
    (void)c; (void)a; (void)b; (void)d; (void)e; (void)f;
    return 0;
}
int fmi2EnterInitializationMode(void *c) { (void)c; return 0; }
int fmi2ExitInitializationMode(void *c) { (void)c; return 0; }
int fmi2Terminate(void *c) { (void)c; return 0; }
int fmi2Reset(void *c) { (void)c; return 0; }

int fmi2SetReal(void *c, const unsigned *vr, size_t n, const double *v) {
    instance *s = c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] == 0) s->y_d = v[i];
        if (vr[i] == 3) s->reference = v[i];
        if (vr[i] == 4) s->measurement = v[i];
    }
    return 0;
}

int fmi2GetReal(void *c, const unsigned *vr, size_t n, double *v) {
    instance *s = c;
    for (size_t i = 0; i < n; i++) v[i] = vr[i] == 1 ? s->u : vr[i] == 5 ? s->correction : 0.0;
    return 0;
}

int fmi2GetInteger(void *c, const unsigned *vr, size_t n, int *v) {
    (void)c; (void)vr;
    for (size_t i = 0; i < n; i++) v[i] = 0;
    return 0;
}

int fmi2GetBoolean(void *c, const unsigned *vr, size_t n, int *v) {
    instance *s = c;
    for (size_t i = 0; i < n; i++) v[i] = vr[i] == 2 ? s->saturated : 0;
    return 0;
}

int fmi2DoStep(void *c, double t, double h, int no_set_prior) {
    (void)t; (void)h; (void)no_set_prior;
    instance *s = c;
    if (steps++ >= TRIGGER) {
        switch (HOSTILE) {
        case 1: { volatile int *z = 0; *z = 1; break; }
        case 2:
            if (fork() == 0) { sleep(1000); _exit(0); }
            for (;;) pause();
        case 3: abort();
        case 4: exit(0);
        case 6: s->u = 2.0 * s->y_d; return 0;
        case 7: { double t0 = now_us(); while (now_us() - t0 < 20.0) {} break; }
        default: break;
        }
    }
    s->u = s->y_d;
    s->correction = 0.0;
    s->saturated = 0;
    return 0;
}

int fmi2GetFMUstate(void *c, void **state) { (void)c; (void)state; return 3; }
int fmi2SetFMUstate(void *c, void *state) { (void)c; (void)state; return 3; }
int fmi2FreeFMUstate(void *c, void **state) { (void)c; (void)state; return 3; }
