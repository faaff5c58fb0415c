/* The hand-written C peer of the compensator step: the straightforward loops
 * of the play (20), the creep operators (20), the compensator (21) and the
 * inverse state rule (22) at the paper's order, branch-free with fmax/fmin,
 * sizes fixed at compile time. Built by run.sh with
 *   cc -O3 -march=native -ffast-math
 * The nominal model (12 plays at r_i = 1000 i / 12 V; creep with the same
 * thresholds and five eigenvalues) is written out here.
 *
 *   compensator time    per-step median over batches, in ns, on stdout
 *   compensator trace   y_d,u_peer of the first 4096 samples as CSV, to check it
 *
 * Built with -DPEER_LIB -shared -fPIC it is a library instead (peer_new,
 * peer_targets, peer_run) for the interleaved comparison in benches/peers.rs.
 * With -DBRANCH_FREE the compensator step is the strongest peer: the same
 * loops without the target test, the forward plays and the re-seat.
 *
 * The input is the random walk of benches/common (same generator and
 * constants); the targets are W of it, computed here by the forward model.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define NP 12 /* plays */
#define NC 12 /* creep thresholds */
#define M 5   /* creep eigenvalues */
#define TS 2e-4
#define LEN 4096

static const double HW[NP] = {0.45,   0.0963, 0.0773, 0.062,  0.0498, 0.0399,
                              0.0321, 0.0257, 0.0206, 0.0166, 0.0133, -0.01};
static const double CW[NC] = {0.08,  0.006, 0.005, 0.004, 0.003, 0.002,
                              0.002, 0.001, 0.001, 0.001, 0.001, 0.001};
static const double EIG[M] = {500.0, 50.0, 5.0, 0.5, 0.05};

typedef struct {
    double r[NP], w[NP], s[NP], x[NP];   /* H: thresholds, weights, sums, states */
    double ri[NP], wi[NP], xi[NP];       /* H^-1 by (22) */
    double rc[NC], wc[NC], g[M];         /* creep: thresholds, w_i / m, 1 - e^(-a T) */
    double chi[M][NC];
    double creep_out, last_u, lower, upper;
} compensator;

typedef struct {
    double r[NP], w[NP], x[NP];
    double rc[NC], wc[NC], g[M];
    double chi[M][NC];
    double creep_out;
} model;

static void init_creep(double *rc, double *wc, double *g) {
    for (int i = 0; i < NC; i++) {
        rc[i] = (i * 1000.0) / 12.0;
        wc[i] = CW[i] / M;
    }
    for (int j = 0; j < M; j++) g[j] = -expm1(-EIG[j] * TS);
}

static void init_compensator(compensator *c) {
    memset(c, 0, sizeof *c);
    double s = 0.0;
    for (int i = 0; i < NP; i++) {
        c->r[i] = (i * 1000.0) / 12.0;
        c->w[i] = HW[i];
        s += HW[i];
        c->s[i] = s;
    }
    c->ri[0] = 0.0;
    c->wi[0] = 1.0 / c->w[0];
    for (int j = 1; j < NP; j++) {
        c->ri[j] = c->ri[j - 1] + c->s[j - 1] * (c->r[j] - c->r[j - 1]);
        c->wi[j] = -c->w[j] / (c->s[j] * c->s[j - 1]);
    }
    init_creep(c->rc, c->wc, c->g);
    c->lower = -1000.0;
    c->upper = 1000.0;
}

static double creep_advance(double chi[M][NC], const double *rc, const double *wc,
                            const double *g, double v) {
    double out = 0.0;
    for (int j = 0; j < M; j++)
        for (int i = 0; i < NC; i++) {
            double z = v - chi[j][i];
            double d = fmax(z - rc[i], fmin(z + rc[i], 0.0));
            chi[j][i] += g[j] * d;
            out += wc[i] * chi[j][i];
        }
    return out;
}

#ifdef BRANCH_FREE
/* The strongest peer (-DBRANCH_FREE): only the arithmetic every step needs.
 * No test of the target, no forward plays, no re-seat after a clipped
 * sample: the loops of (20)-(22) and the clip, straight through. It does
 * less than mfcbeam (a NaN target poisons it; after saturation its H^-1 is
 * on the wrong branch), which the benches' targets never exercise. */
static double compensate(compensator *c, double target, int *saturated) {
    double y = target - c->creep_out;
    double v = 0.0;
    for (int i = 0; i < NP; i++) {
        c->xi[i] = fmax(y - c->ri[i], fmin(y + c->ri[i], c->xi[i]));
        v += c->wi[i] * c->xi[i];
    }
    double u = fmin(fmax(v, c->lower), c->upper);
    *saturated = u != v;
    c->creep_out = creep_advance(c->chi, c->rc, c->wc, c->g, u);
    return u;
}
#else
/* One sample of (21); *saturated set when u was clipped. */
static double compensate(compensator *c, double target, int *saturated) {
    *saturated = 0;
    if (!isfinite(target)) { /* hold the last voltage; creep sees it */
        c->creep_out = creep_advance(c->chi, c->rc, c->wc, c->g, c->last_u);
        return c->last_u;
    }
    double y = target - c->creep_out;
    double v = 0.0;
    for (int i = 0; i < NP; i++) {
        c->xi[i] = fmax(y - c->ri[i], fmin(y + c->ri[i], c->xi[i]));
        v += c->wi[i] * c->xi[i];
    }
    double u = fmin(fmax(v, c->lower), c->upper);
    for (int i = 0; i < NP; i++) c->x[i] = fmax(u - c->r[i], fmin(u + c->r[i], c->x[i]));
    if (u != v) { /* re-seat H^-1 on the branch the actuator is on (22) */
        *saturated = 1;
        double tail = 0.0;
        for (int j = NP - 1; j >= 0; j--) {
            c->xi[j] = c->s[j] * c->x[j] + tail;
            tail += c->w[j] * c->x[j];
        }
    }
    c->last_u = u;
    c->creep_out = creep_advance(c->chi, c->rc, c->wc, c->g, u);
    return u;
}
#endif

static double model_step(model *w, double u) {
    double h = 0.0;
    for (int i = 0; i < NP; i++) {
        w->x[i] = fmax(u - w->r[i], fmin(u + w->r[i], w->x[i]));
        h += w->w[i] * w->x[i];
    }
    double y = h + w->creep_out;
    w->creep_out = creep_advance(w->chi, w->rc, w->wc, w->g, u);
    return y;
}

static void init_model(model *w) {
    memset(w, 0, sizeof *w);
    for (int i = 0; i < NP; i++) {
        w->r[i] = (i * 1000.0) / 12.0;
        w->w[i] = HW[i];
    }
    init_creep(w->rc, w->wc, w->g);
}

static void test_input(double *out) {
    uint64_t state = 0x9E3779B97F4A7C15ull;
    double v = 0.0;
    for (int k = 0; k < LEN; k++) {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        double step = ((double)(state >> 11) / (double)(1ull << 53) - 0.5) * 40.0;
        v = fmin(fmax(v + step, -600.0), 600.0);
        out[k] = v;
    }
}

#ifdef PEER_LIB
/* For benches/peers.rs, which times this and mfcbeam in interleaved batches:
 * the same loop as main's timed one. */
void *peer_new(void) {
    static compensator c;
    init_compensator(&c);
    return &c;
}

void peer_targets(double *out) {
    static double input[LEN];
    test_input(input);
    model w;
    init_model(&w);
    for (int k = 0; k < LEN; k++) out[k] = model_step(&w, input[k]);
}

double peer_run(void *p, const double *targets, unsigned *k, long steps) {
    compensator *c = p;
    double sink = 0.0;
    int sat;
    unsigned kk = *k;
    for (long i = 0; i < steps; i++) {
        kk = (kk + 1) & (LEN - 1);
        sink += compensate(c, targets[kk], &sat);
    }
    *k = kk;
    return sink;
}
#else
static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    static double input[LEN], targets[LEN];
    test_input(input);
    model w;
    init_model(&w);
    for (int k = 0; k < LEN; k++) targets[k] = model_step(&w, input[k]);

    compensator c;
    init_compensator(&c);
    int sat;
    if (argc > 1 && strcmp(argv[1], "trace") == 0) {
        printf("y_d,u_peer\n");
        for (int k = 0; k < LEN; k++) printf("%.17g,%.17g\n", targets[k], compensate(&c, targets[k], &sat));
        return 0;
    }
    if (argc > 1 && strcmp(argv[1], "time") != 0) {
        fprintf(stderr, "usage: %s time|trace\n", argv[0]);
        return 2;
    }
    /* As criterion does: batches of consecutive steps, the median of the
     * per-step means; the target index walks the 4096 targets cyclically. */
    enum { BATCHES = 101, STEPS = 200000 };
    double per_step[BATCHES], sink = 0.0;
    unsigned k = 0;
    for (int warm = 0; warm < 5 * STEPS; warm++) {
        k = (k + 1) & (LEN - 1);
        sink += compensate(&c, targets[k], &sat);
    }
    for (int b = 0; b < BATCHES; b++) {
        double t0 = now();
        for (int i = 0; i < STEPS; i++) {
            k = (k + 1) & (LEN - 1);
            sink += compensate(&c, targets[k], &sat);
        }
        per_step[b] = (now() - t0) / STEPS * 1e9;
    }
    qsort(per_step, BATCHES, sizeof per_step[0], cmp);
    printf("%.2f\n", per_step[BATCHES / 2]);
    return sink == 12345.678 ? 1 : 0; /* keep the results live */
}
#endif
