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
 * Built with -DSTEP_ABI -shared -fPIC it is a candidate library of the step
 * ABI (mfcbeam bench, mfcbeam conform --library).
 * Built with -DPEER_LIB -shared -fPIC it is a library instead (peer_new,
 * peer_targets, peer_run) for the interleaved comparison in benches/peers.rs.
 * With -DBRANCH_FREE the step is the same loops without the target test,
 * the forward plays and the re-seat; with -DSTRONG (optionally -DNO_FMA) it
 * is the strongest peer, AVX2 intrinsics written for the dependency chain
 * (with -DONE_CALL the same, called once per sample, not inlined);
 * with -DSTRONG_F32 the strongest in single precision; with -DSAME_ORDER it
 * is mfcbeam's step, its order of operations in intrinsics (each described
 * where it is defined).
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

#if defined(SAME_ORDER)
/* mfcbeam's step in C (-DSAME_ORDER): its operations in its order, with
 * intrinsics — H^-1's plays in three 4-lane blocks, the creep pass in the
 * 8-lane block and the 4-lane block of its AVX-512 kernels (three 4-lane
 * blocks on AVX2, the same sums lane by lane), FMA where
 * mfcbeam fuses (the creep update g c + (x - g x), each weighted term
 * after a sum's first, a product, with its sum), the plays saved before each step for a re-seat, a non-finite target held —
 * so its voltages have mfcbeam's bits (run.sh checks that they are equal,
 * not close). Against the strongest peer it shows what the order of the
 * arithmetic costs; against mfcbeam, what the Rust around it costs.
 * Built like the strongest (-ffp-contract=off, no -ffast-math). */
#include <immintrin.h>

typedef struct {
    double ri[NP], wi[NP], xi[NP], saved[NP];
    double rc[NC], wc[NC], g[M];
    double chi[M][NC];
    double creep_out, creep_last, last_u, lower, upper;
} same;

static void init_same(same *c) {
    compensator base;
    init_compensator(&base);
    memset(c, 0, sizeof *c);
    memcpy(c->ri, base.ri, sizeof c->ri);
    memcpy(c->wi, base.wi, sizeof c->wi);
    memcpy(c->rc, base.rc, sizeof c->rc);
    memcpy(c->wc, base.wc, sizeof c->wc);
    memcpy(c->g, base.g, sizeof c->g);
    c->lower = base.lower;
    c->upper = base.upper;
}

/* (a0 + a2) + (a1 + a3), as mfcbeam's reduce */
static inline double reduce4(__m256d a) {
    __m128d s = _mm_add_pd(_mm256_castpd256_pd128(a), _mm256_extractf128_pd(a, 1));
    return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}

/* the weighted term w x into a partial sum: the product alone for a sum's
 * first term (first), fused with the sum after it, as mfcbeam adds them */
static inline __m256d term4(int first, __m256d w, __m256d x, __m256d acc) {
    return first ? _mm256_mul_pd(w, x) : _mm256_fmadd_pd(w, x, acc);
}

/* play i0..i0+3 of H^-1 at y = t - cr into acc (lane l: the thresholds
 * l mod 4); the bounds (t -+ r) - cr, as mfcbeam forms them */
static inline __m256d play4(same *c, int i0, __m256d t, __m256d cr, __m256d acc) {
    __m256d r = _mm256_loadu_pd(c->ri + i0), x = _mm256_loadu_pd(c->xi + i0);
    _mm256_storeu_pd(c->saved + i0, x);
    x = _mm256_max_pd(_mm256_min_pd(x, _mm256_sub_pd(_mm256_add_pd(t, r), cr)),
                      _mm256_sub_pd(_mm256_sub_pd(t, r), cr));
    _mm256_storeu_pd(c->xi + i0, x);
    return term4(i0 == 0, _mm256_loadu_pd(c->wi + i0), x, acc);
}

/* creep thresholds i0..i0+3, every eigenvalue, into acc */
static inline __m256d creep4(same *c, int i0, __m256d u, __m256d acc) {
    __m256d r = _mm256_loadu_pd(c->rc + i0);
    __m256d lo = _mm256_sub_pd(u, r), hi = _mm256_add_pd(u, r);
    __m256d rows = _mm256_setzero_pd(); /* replaced by the first row */
    for (int j = 0; j < M; j++) {
        __m256d x = _mm256_loadu_pd(c->chi[j] + i0), g = _mm256_set1_pd(c->g[j]);
        __m256d cl = _mm256_max_pd(_mm256_min_pd(x, hi), lo);
        x = _mm256_fmadd_pd(g, cl, _mm256_fnmadd_pd(g, x, x)); /* g c + (x - g x) */
        _mm256_storeu_pd(c->chi[j] + i0, x);
        rows = j == 0 ? x : _mm256_add_pd(rows, x);
    }
    return term4(i0 == 0, _mm256_loadu_pd(c->wc + i0), rows, acc);
}

#ifdef __AVX512F__
/* w x in lanes 0..7 as two blocks of four, the second fused with the
 * first's products: fma(w_hi, x_hi, w_lo x_lo) */
static inline __m256d halves(__m512d w, __m512d x) {
    __m256d acc = _mm256_mul_pd(_mm512_castpd512_pd256(w), _mm512_castpd512_pd256(x));
    return _mm256_fmadd_pd(_mm512_extractf64x4_pd(w, 1), _mm512_extractf64x4_pd(x, 1), acc);
}
#endif

static double compensate_same(same *c, double target, int *saturated) {
    *saturated = 0;
    if (__builtin_expect(!isfinite(target), 0)) { /* hold; creep sees it */
        c->creep_out = creep_advance(c->chi, c->rc, c->wc, c->g, c->last_u);
        return c->last_u;
    }
    double t = target, cr = c->creep_out;
    if (__builtin_expect(!isfinite(t - cr), 0)) {
        t = c->xi[0];
        cr = 0.0;
    }
    __m256d t4 = _mm256_set1_pd(t), c4 = _mm256_set1_pd(cr), acc;
    acc = play4(c, 4, t4, c4, play4(c, 0, t4, c4, _mm256_setzero_pd()));
    double u = reduce4(play4(c, 8, t4, c4, acc));
    if (u < c->lower) {
        u = c->lower;
        *saturated = 1;
    } else if (u > c->upper) {
        u = c->upper;
        *saturated = 1;
    }
    c->last_u = u;
    if (__builtin_expect(!isfinite(u), 0)) u = c->creep_last;
    c->creep_last = u;
    __m256d u4 = _mm256_set1_pd(u);
#ifdef __AVX512F__
    {
        __m512d u8 = _mm512_set1_pd(u), r = _mm512_loadu_pd(c->rc);
        __m512d lo = _mm512_sub_pd(u8, r), hi = _mm512_add_pd(u8, r);
        __m512d rows = _mm512_setzero_pd(); /* replaced by the first row */
        for (int j = 0; j < M; j++) {
            __m512d x = _mm512_loadu_pd(c->chi[j]), g = _mm512_set1_pd(c->g[j]);
            __m512d cl = _mm512_max_pd(_mm512_min_pd(x, hi), lo);
            x = _mm512_fmadd_pd(g, cl, _mm512_fnmadd_pd(g, x, x));
            _mm512_storeu_pd(c->chi[j], x);
            rows = j == 0 ? x : _mm512_add_pd(rows, x);
        }
        acc = halves(_mm512_loadu_pd(c->wc), rows);
    }
#else
    acc = creep4(c, 4, u4, creep4(c, 0, u4, _mm256_setzero_pd()));
#endif
    c->creep_out = reduce4(creep4(c, 8, u4, acc));
    return c->last_u;
}
#define compensator same
#define init_compensator init_same
#define compensate compensate_same
#elif defined(STRONG_F32)
/* The strongest peer in single precision (-DSTRONG_F32): -DSTRONG's design
 * (a running creep sum re-summed every RESUM steps, only dC on the chain,
 * H^-1's bounds formed before dC, sums as trees ending in a butterfly, the
 * clip a predicted branch; no target test, no forward plays, no re-seat),
 * in float, eight lanes per AVX2 register instead of four: H^-1 in two
 * registers (plays 0-7, then 8-11 and four empty lanes), the creep's 60
 * elements in eight (thresholds 0-7 of row j in register j; thresholds
 * 8-11 of rows 0 and 1, 2 and 3, 4 and four empty lanes in registers 5-7),
 * against three and fifteen in double. The target arrives as a double and
 * is rounded to float, the voltage leaves as a double (both off the
 * chain). An empty lane has no weight, no gain and a zero state, so it adds
 * exact zeros. What it shows: what half the bytes and twice the lanes buy
 * a hand-written step whose dependency chain has the same operations. */
#include <immintrin.h>

#define G32 8 /* creep registers */
#define RESUM 1024

typedef struct {
    __m256 ri[2], wi[2], xi[2];                 /* H^-1 */
    __m256 r[2], q[G32], g[G32], h[G32], wc[G32], chi[G32]; /* creep */
    __m256 dc;                                  /* dC, in every lane */
    float lower, upper, c_prev;
    int count;
} strong32;

/* s in every lane summed, in all eight lanes */
static inline __m256 all_lanes_sum8(__m256 s) {
    s = _mm256_add_ps(s, _mm256_permute2f128_ps(s, s, 1));
    s = _mm256_add_ps(s, _mm256_permute_ps(s, 0x4E));
    return _mm256_add_ps(s, _mm256_permute_ps(s, 0xB1));
}

__attribute__((noinline, cold)) static float creep_sum32(const strong32 *c) {
    __m256 s = _mm256_setzero_ps();
    for (int e = 0; e < G32; e++) s = _mm256_fmadd_ps(c->wc[e], c->chi[e], s);
    return _mm256_cvtss_f32(all_lanes_sum8(s));
}

/* register e, lane l of the creep: its threshold and eigenvalue (-1: empty) */
static void creep_lane(int e, int l, int *i, int *j) {
    if (e < M) {
        *i = l;
        *j = e;
    } else {
        *i = NC - 4 + l % 4;
        *j = 2 * (e - M) + l / 4;
        if (*j >= M) *i = *j = -1;
    }
}

static void init_strong32(strong32 *c) {
    compensator base;
    init_compensator(&base);
    memset(c, 0, sizeof *c);
    float ri[16] = {0}, wi[16] = {0}, r[16];
    for (int i = 0; i < NP; i++) {
        ri[i] = (float)base.ri[i];
        wi[i] = (float)base.wi[i];
    }
    for (int l = 0; l < 8; l++) {
        r[l] = (float)base.rc[l];
        r[8 + l] = (float)base.rc[NC - 4 + l % 4];
    }
    for (int b = 0; b < 2; b++) {
        c->ri[b] = _mm256_loadu_ps(ri + 8 * b);
        c->wi[b] = _mm256_loadu_ps(wi + 8 * b);
        c->r[b] = _mm256_loadu_ps(r + 8 * b);
    }
    for (int e = 0; e < G32; e++) {
        float q[8], g[8], h[8], wc[8];
        for (int l = 0; l < 8; l++) {
            int i, j;
            creep_lane(e, l, &i, &j);
            g[l] = j < 0 ? 0.0f : (float)base.g[j];
            h[l] = j < 0 ? 0.0f : (float)(1.0 - base.g[j]);
            wc[l] = j < 0 ? 0.0f : (float)base.wc[i];
            q[l] = j < 0 ? 0.0f : (float)(base.wc[i] * base.g[j]);
        }
        c->q[e] = _mm256_loadu_ps(q);
        c->g[e] = _mm256_loadu_ps(g);
        c->h[e] = _mm256_loadu_ps(h);
        c->wc[e] = _mm256_loadu_ps(wc);
    }
    c->lower = (float)base.lower;
    c->upper = (float)base.upper;
}

/* dC for the input u (in all lanes), chi advanced with it. */
static inline __m256 strong32_creep(strong32 *c, __m256 u) {
    __m256 lo[2], hi[2], p[G32];
    for (int b = 0; b < 2; b++) {
        lo[b] = _mm256_sub_ps(u, c->r[b]);
        hi[b] = _mm256_add_ps(u, c->r[b]);
    }
    for (int e = 0; e < G32; e++) {
        int b = e < M ? 0 : 1;
        __m256 x = c->chi[e];
        __m256 clamped = _mm256_max_ps(_mm256_min_ps(x, hi[b]), lo[b]);
        p[e] = _mm256_fmsub_ps(c->q[e], clamped, _mm256_mul_ps(c->q[e], x));
        c->chi[e] = _mm256_fmadd_ps(c->g[e], clamped, _mm256_mul_ps(c->h[e], x));
    }
    __m256 a0 = _mm256_add_ps(p[0], p[4]), a1 = _mm256_add_ps(p[1], p[5]);
    __m256 a2 = _mm256_add_ps(p[2], p[6]), a3 = _mm256_add_ps(p[3], p[7]);
    return all_lanes_sum8(_mm256_add_ps(_mm256_add_ps(a0, a2), _mm256_add_ps(a1, a3)));
}

static double compensate_strong32(strong32 *c, double target, int *saturated) {
    __m256 dc = c->dc;
    __m256 z = _mm256_set1_ps((float)target - c->c_prev);
    __m256 s[2];
    for (int b = 0; b < 2; b++) {
        __m256 hi = _mm256_sub_ps(_mm256_add_ps(z, c->ri[b]), dc);
        __m256 lo = _mm256_sub_ps(_mm256_sub_ps(z, c->ri[b]), dc);
        c->xi[b] = _mm256_max_ps(_mm256_min_ps(c->xi[b], hi), lo);
        s[b] = _mm256_mul_ps(c->wi[b], c->xi[b]);
    }
    __m256 v = all_lanes_sum8(_mm256_add_ps(s[0], s[1]));
    float vs = _mm256_cvtss_f32(v);
    *saturated = !(vs >= c->lower && vs <= c->upper);
    if (__builtin_expect(*saturated, 0)) {
        vs = fminf(fmaxf(vs, c->lower), c->upper);
        v = _mm256_set1_ps(vs);
    }
    __m256 d = strong32_creep(c, v);
    c->c_prev += _mm256_cvtss_f32(dc);
    c->dc = d;
    if (__builtin_expect(++c->count == RESUM, 0)) {
        c->count = 0;
        c->c_prev = creep_sum32(c);
        c->dc = _mm256_setzero_ps();
    }
    return vs;
}
#define compensator strong32
#define init_compensator init_strong32
#define compensate compensate_strong32
#elif defined(STRONG)
/* The strongest peer (-DSTRONG): AVX2 intrinsics with FMA, written for one
 * step's dependency chain, u_{k-1} -> creep -> H^-1 -> clip -> u_k, and for
 * few operations per step:
 *  - the creep output is a running sum, C_{k+1} = C_k + dC_k with
 *    dC_k = sum_ij (w_i g_j / m) (c_ij - chi_ij), c = clamp(chi, u - r,
 *    u + r), re-summed from chi every RESUM steps;
 *  - only dC is on the chain: each term is q c - q chi and each state
 *    update g c + (1 - g) chi, one FMA after the clamp with its product of
 *    chi formed before u is known (six operations per register of four;
 *    g, 1 - g and q kept per register, nothing rebuilt per step); u -+ r
 *    are shared by the five rows;
 *  - the bounds of H^-1's plays are (t -+ r' - C_{k-1}) - dC_{k-1}: one
 *    subtraction after dC, the rest formed early;
 *  - every sum is a tree (the creep's 15 products of depth 4) ending in a
 *    butterfly that leaves it in all four lanes, and dC stays a vector from
 *    one step to the next (no scalar round trip, no broadcast);
 *  - the clip is a predicted branch: the creep runs on v, and only a
 *    clipped sample (never, on the benches' targets) redoes it with u.
 * Like BRANCH_FREE it does no target test, no forward plays and no re-seat.
 * Built without -ffast-math but with -ffp-contract=off: the trees are as
 * written (-ffast-math turns them into serial FMA chains, 12 % slower). */
#include <immintrin.h>

#ifdef NO_FMA
/* -DNO_FMA: each fused multiply-add as a multiply and an add (two
 * roundings), as mfcbeam computes: what the FMA is worth to this peer */
#define _mm256_fmadd_pd(a, b, c) _mm256_add_pd(_mm256_mul_pd(a, b), c)
#define _mm256_fmsub_pd(a, b, c) _mm256_sub_pd(_mm256_mul_pd(a, b), c)
#endif

#define G 15 /* creep groups of four: 5 rows of 12 thresholds */
#define RESUM 1024

typedef struct {
    __m256d ri[3], wi[3], xi[3];        /* H^-1 */
    __m256d r[3], q[G], g[G], h[G], chi[G]; /* creep; group b of row j is j * 3 + b */
    __m256d dc;                             /* dC, in every lane */
    double wc[NC];
    double lower, upper, c_prev;
    int count;
} strong;

static inline __m256d all_lanes_sum(__m256d s) {
    s = _mm256_add_pd(s, _mm256_permute2f128_pd(s, s, 1));
    return _mm256_add_pd(s, _mm256_permute_pd(s, 5));
}

__attribute__((noinline, cold)) static double creep_sum(const strong *c) {
    double out = 0.0;
    for (int j = 0; j < M; j++)
        for (int b = 0; b < 3; b++)
            for (int l = 0; l < 4; l++) out += c->wc[4 * b + l] * c->chi[j * 3 + b][l];
    return out;
}

static void init_strong(strong *c) {
    compensator base;
    init_compensator(&base);
    memset(c, 0, sizeof *c);
    for (int b = 0; b < 3; b++) {
        c->ri[b] = _mm256_loadu_pd(base.ri + 4 * b);
        c->wi[b] = _mm256_loadu_pd(base.wi + 4 * b);
        c->r[b] = _mm256_loadu_pd(base.rc + 4 * b);
    }
    for (int j = 0; j < M; j++)
        for (int b = 0; b < 3; b++) {
            double q[4];
            for (int l = 0; l < 4; l++) q[l] = base.wc[4 * b + l] * base.g[j];
            c->q[j * 3 + b] = _mm256_loadu_pd(q);
            c->g[j * 3 + b] = _mm256_set1_pd(base.g[j]);
            c->h[j * 3 + b] = _mm256_set1_pd(1.0 - base.g[j]);
        }
    memcpy(c->wc, base.wc, sizeof c->wc);
    c->lower = base.lower;
    c->upper = base.upper;
}

/* dC for the input u (in all lanes), chi advanced with it. */
static inline __m256d strong_creep(strong *c, __m256d u) {
    __m256d p[G], lo[3], hi[3];
    for (int b = 0; b < 3; b++) {
        lo[b] = _mm256_sub_pd(u, c->r[b]);
        hi[b] = _mm256_add_pd(u, c->r[b]);
    }
    for (int e = 0; e < G; e++) {
        __m256d x = c->chi[e];
        __m256d clamped = _mm256_max_pd(_mm256_min_pd(x, hi[e % 3]), lo[e % 3]);
        p[e] = _mm256_fmsub_pd(c->q[e], clamped, _mm256_mul_pd(c->q[e], x));
        c->chi[e] = _mm256_fmadd_pd(c->g[e], clamped, _mm256_mul_pd(c->h[e], x));
    }
    __m256d a0 = _mm256_add_pd(p[0], p[8]), a1 = _mm256_add_pd(p[1], p[9]);
    __m256d a2 = _mm256_add_pd(p[2], p[10]), a3 = _mm256_add_pd(p[3], p[11]);
    __m256d a4 = _mm256_add_pd(p[4], p[12]), a5 = _mm256_add_pd(p[5], p[13]);
    __m256d a6 = _mm256_add_pd(p[6], p[14]);
    a0 = _mm256_add_pd(a0, a4);
    a1 = _mm256_add_pd(a1, a5);
    a2 = _mm256_add_pd(a2, a6);
    a3 = _mm256_add_pd(a3, p[7]);
    return all_lanes_sum(_mm256_add_pd(_mm256_add_pd(a0, a2), _mm256_add_pd(a1, a3)));
}

#ifdef ONE_CALL
/* -DONE_CALL: the step kept out of the caller's loop, one call per sample
 * as a controller calls it; inlined into a loop over samples (peer_run),
 * the compiler keeps its constants and dC in registers from one sample to
 * the next */
__attribute__((noinline))
#endif
static double compensate_strong(strong *c, double target, int *saturated) {
    __m256d dc = c->dc;
    __m256d z = _mm256_set1_pd(target - c->c_prev);
    __m256d s[3];
    for (int b = 0; b < 3; b++) {
        __m256d hi = _mm256_sub_pd(_mm256_add_pd(z, c->ri[b]), dc);
        __m256d lo = _mm256_sub_pd(_mm256_sub_pd(z, c->ri[b]), dc);
        c->xi[b] = _mm256_max_pd(_mm256_min_pd(c->xi[b], hi), lo);
        s[b] = _mm256_mul_pd(c->wi[b], c->xi[b]);
    }
    __m256d v = all_lanes_sum(_mm256_add_pd(_mm256_add_pd(s[0], s[2]), s[1]));
    double vs = _mm256_cvtsd_f64(v);
    *saturated = !(vs >= c->lower && vs <= c->upper);
    if (__builtin_expect(*saturated, 0)) {
        vs = fmin(fmax(vs, c->lower), c->upper);
        v = _mm256_set1_pd(vs);
    }
    __m256d d = strong_creep(c, v);
    c->c_prev += _mm256_cvtsd_f64(dc);
    c->dc = d;
    if (__builtin_expect(++c->count == RESUM, 0)) {
        c->count = 0;
        c->c_prev = creep_sum(c);
        c->dc = _mm256_setzero_pd();
    }
    return vs;
}
#define compensator strong
#define init_compensator init_strong
#define compensate compensate_strong
#elif defined(BRANCH_FREE)
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

#ifndef STEP_ABI /* the forward model and the test input: not in a candidate */
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
#endif

#ifdef BANK_PEER
/* included by bank.c, which brings its own entry points */
#elif defined(STEP_ABI)
/* The step ABI of `mfcbeam bench` and `mfcbeam conform --library`
 * (include/mfcbeam_candidate.h): this peer as a user's compensator with its
 * model compiled in. It ignores the model file and takes the limits. */
#include <stdlib.h>
typedef struct {
    compensator c;
    int saturated;
} step_abi;

void *mfcbeam_candidate_create(const char *model_file, double lower, double upper) {
    (void)model_file;
    step_abi *s = malloc(sizeof *s);
    if (!s) return NULL;
    init_compensator(&s->c);
    s->c.lower = lower;
    s->c.upper = upper;
    s->saturated = 0;
    return s;
}

double mfcbeam_candidate_step(void *p, double target) {
    step_abi *s = p;
    return compensate(&s->c, target, &s->saturated);
}

int mfcbeam_candidate_saturated(const void *p) { return ((const step_abi *)p)->saturated; }

void mfcbeam_candidate_free(void *p) { free(p); }
#elif defined(PEER_LIB)
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
