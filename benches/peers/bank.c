/* The hand-written C peer of the compensator bank (CompensatorBank<f64>,
 * one shared model): AVX-512F intrinsics, a block of eight channels in one
 * register, the sizes fixed at compile time (12 plays, 12 creep thresholds
 * x 5 eigenvalues: every loop unrolled by the compiler), each lane in
 * mfcbeam's order of operations, so its voltages have mfcbeam's bits:
 *  - y = t' - C with t' = t - offset, t' and C held at the first inverse
 *    play's state and 0 where y is not finite; a non-finite target holds
 *    the voltage (its plays keep their state) and the creep sees the
 *    voltage held;
 *  - H^-1 (22): x <- max(min(x, (t' + r') - C), (t' - r') - C), t' +- r'
 *    fused as +-(r' . 1) + t', the weighted terms into four partial sums
 *    (play i into sum i mod 4; each sum's first term a product, the later
 *    ones fused with it), (s0 + s2) + (s1 + s3);
 *  - the clip, the saturated lanes re-seated lane by lane as mfcbeam does;
 *  - the creep pass (20): per threshold the five updates
 *    chi <- g c + (chi - g chi) (two FMAs, c = max(min(chi, u + r), u - r)),
 *    their sum from zero (thresholds two at a time, the first's rows by
 *    add, the second's by chi . 1 + rows), with its weight into sum
 *    i mod 4 (as H^-1's terms).
 * A step is software-pipelined by one block, as mfcbeam's: H^-1 and the clip
 * of block b + 1 before the creep pass of block b. The output is mfcbeam's
 * Compensated<f64> (u, saturated, fault: 16 bytes a channel).
 *
 *   bank trace    y_d,u_peer of lane 3 of a bank of 8 channels (lane l sees
 *                 the targets 37 l samples on), 4096 samples, as CSV
 *   bank steps C  200 steps of a bank of C channels (a multiple of 8), for
 *                 counting the instructions of one bank_step
 *                 (count_instructions.py)
 *
 * Built with -DPEER_LIB -shared -fPIC it is a library for bank_limit's
 * interleaved comparison (bank_new, bank_run). Needs AVX-512F.
 * Built like the strongest single-step peer: -O3 -march=native
 * -ffp-contract=off (the sums as written); its loops unrolled by pragmas
 * (rolled, gcc 12 keeps the creep's bounds and rows in memory: half the
 * speed). */
#define BANK_PEER
#include "compensator.c"

#include <immintrin.h>

/* rows of a block's state: the inverse plays (two copies), chi, the last
 * voltage, the creep output, the creep input */
enum { X0 = 0, CHI = 2 * NP, LAST_U = CHI + NC * M, CREEP_OUT, CREEP_LAST, ROWS };

typedef struct {
    long channels, blocks;
    int parity;
    __m512d *state; /* blocks x ROWS */
    __m512d ri[NP], wi[NP], rc[NC], wc[NC], g[M], offset, lower, upper, one;
    double r[NP], w[NP], s[NP]; /* H, for a re-seat */
} bank;

typedef struct {
    double u;
    unsigned char saturated, fault;
} compensated;

static bank *bank_create(long channels) {
    compensator c;
    init_compensator(&c);
    bank *b = aligned_alloc(64, (sizeof *b + 63) / 64 * 64); /* __m512d members */
    if (!b) return NULL;
    memset(b, 0, sizeof *b);
    b->channels = channels;
    b->blocks = (channels + 7) / 8;
    b->state = aligned_alloc(64, (size_t)b->blocks * ROWS * sizeof(__m512d));
    if (!b->state) return NULL;
    memset(b->state, 0, (size_t)b->blocks * ROWS * sizeof(__m512d));
    for (int i = 0; i < NP; i++) {
        b->ri[i] = _mm512_set1_pd(c.ri[i]);
        b->wi[i] = _mm512_set1_pd(c.wi[i]);
        b->r[i] = c.r[i];
        b->w[i] = c.w[i];
        b->s[i] = c.s[i];
    }
    for (int i = 0; i < NC; i++) {
        b->rc[i] = _mm512_set1_pd(c.rc[i]);
        b->wc[i] = _mm512_set1_pd(c.wc[i]);
    }
    for (int j = 0; j < M; j++) b->g[j] = _mm512_set1_pd(c.g[j]);
    b->offset = _mm512_setzero_pd();
    b->lower = _mm512_set1_pd(c.lower);
    b->upper = _mm512_set1_pd(c.upper);
    volatile double one = 1.0; /* not a constant: the fused forms stay */
    b->one = _mm512_set1_pd(one);
    return b;
}

static inline __mmask8 non_finite(__m512d x) {
    return _mm512_cmp_pd_mask(_mm512_sub_pd(x, x), _mm512_setzero_pd(), _CMP_NEQ_UQ);
}

/* mfcbeam's re-seat of a saturated lane: H's plays from the inverse plays
 * before the step, advanced with the applied u, and H^-1's from them */
static __attribute__((noinline, cold)) void reseat(const bank *b, __m512d *s, unsigned lanes, int cur) {
    int next = cur ^ 1;
    double *x = (double *)s;
    for (int l = 0; l < 8; l++) {
        if (!(lanes >> l & 1)) continue;
        double u = x[LAST_U * 8 + l];
#define OLD(i) x[(X0 + cur * NP + (i)) * 8 + l]
#define NEW(i) x[(X0 + next * NP + (i)) * 8 + l]
        double next_inv = OLD(NP - 1);
        NEW(NP - 1) = next_inv / b->s[NP - 1];
        for (int j = NP - 2; j >= 0; j--) {
            double inv = OLD(j);
            NEW(j) = NEW(j + 1) + (inv - next_inv) / b->s[j];
            next_inv = inv;
        }
        for (int j = 0; j < NP; j++) {
            double lo = u - b->r[j], hi = u + b->r[j], v = NEW(j);
            double t = v < hi ? v : hi;
            NEW(j) = t > lo ? t : lo;
        }
        double tail = 0.0;
        for (int j = NP - 1; j >= 0; j--) {
            double forward = NEW(j);
            NEW(j) = b->s[j] * forward + tail;
            tail += b->w[j] * forward;
        }
#undef OLD
#undef NEW
    }
}

static inline __attribute__((always_inline)) void first_part(const bank *restrict b, __m512d *restrict s,
                                                             const double *restrict t,
                                                             compensated *restrict out, int cur) {
    int next = cur ^ 1;
    __m512d target = _mm512_loadu_pd(t);
    __mmask8 fault = non_finite(target);
    __m512d t1 = _mm512_sub_pd(target, b->offset), cr = s[CREEP_OUT];
    __mmask8 held = non_finite(_mm512_sub_pd(t1, cr));
    t1 = _mm512_mask_blend_pd(held, t1, s[X0 + cur * NP]);
    cr = _mm512_mask_blend_pd(held, cr, _mm512_setzero_pd());
    __m512d sums[4] = {_mm512_setzero_pd(), _mm512_setzero_pd(), _mm512_setzero_pd(),
                       _mm512_setzero_pd()};
    #pragma GCC unroll 16
    for (int i = 0; i < NP; i++) {
        __m512d x = s[X0 + cur * NP + i];
        __m512d lo = _mm512_sub_pd(_mm512_fnmadd_pd(b->ri[i], b->one, t1), cr);
        __m512d hi = _mm512_sub_pd(_mm512_fmadd_pd(b->ri[i], b->one, t1), cr);
        __m512d nx = _mm512_max_pd(_mm512_min_pd(x, hi), lo);
        s[X0 + next * NP + i] = _mm512_mask_blend_pd(fault, nx, x);
        sums[i & 3] = i < 4 ? _mm512_mul_pd(b->wi[i], nx) : _mm512_fmadd_pd(b->wi[i], nx, sums[i & 3]);
    }
    __m512d v = _mm512_add_pd(_mm512_add_pd(sums[0], sums[2]), _mm512_add_pd(sums[1], sums[3]));
    __mmask8 below = _mm512_cmp_pd_mask(v, b->lower, _CMP_LT_OQ);
    __mmask8 above = _mm512_cmp_pd_mask(v, b->upper, _CMP_GT_OQ);
    __m512d clipped = _mm512_mask_blend_pd(below, _mm512_mask_blend_pd(above, v, b->upper), b->lower);
    __m512d u = _mm512_mask_blend_pd(fault, clipped, s[LAST_U]);
    __mmask8 saturated = (below | above) & ~fault;
    s[LAST_U] = u;
    if (__builtin_expect(saturated != 0, 0)) reseat(b, s, saturated, cur);
    s[CREEP_LAST] = _mm512_mask_blend_pd(non_finite(u), u, s[CREEP_LAST]);
    __m512d flags = _mm512_castsi512_pd(_mm512_or_si512(_mm512_maskz_set1_epi64(saturated, 1),
                                                        _mm512_maskz_set1_epi64(fault, 1 << 8)));
    double *o = (double *)out;
    _mm512_storeu_pd(o, _mm512_permutex2var_pd(u, _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11), flags));
    _mm512_storeu_pd(o + 8, _mm512_permutex2var_pd(u, _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15), flags));
}

static inline __attribute__((always_inline)) void creep_pass(const bank *restrict b, __m512d *restrict s) {
    __m512d uc = s[CREEP_LAST];
    __m512d sums[4] = {_mm512_setzero_pd(), _mm512_setzero_pd(), _mm512_setzero_pd(),
                       _mm512_setzero_pd()};
    /* two thresholds at a time: 2-6 % faster here than four at a time (the
     * same bits: each threshold's weighted rows still go into sum i mod 4) */
    #pragma GCC unroll 16
    for (int i0 = 0; i0 < NC; i0 += 2) {
        __m512d lo[2], hi[2], rows[2];
        #pragma GCC unroll 16
        for (int q = 0; q < 2; q++) {
            lo[q] = _mm512_sub_pd(uc, b->rc[i0 + q]);
            hi[q] = _mm512_add_pd(uc, b->rc[i0 + q]);
            rows[q] = _mm512_setzero_pd();
        }
        #pragma GCC unroll 16
        for (int j = 0; j < M; j++) {
            #pragma GCC unroll 16
            for (int q = 0; q < 2; q++) {
                __m512d *chi = &s[CHI + (i0 + q) * M + j];
                __m512d x = *chi, g = b->g[j];
                __m512d c = _mm512_max_pd(_mm512_min_pd(x, hi[q]), lo[q]);
                x = _mm512_fmadd_pd(g, c, _mm512_fnmadd_pd(g, x, x));
                *chi = x;
                rows[q] = q == 0 ? _mm512_add_pd(rows[q], x) : _mm512_fmadd_pd(x, b->one, rows[q]);
            }
        }
        #pragma GCC unroll 16
        for (int q = 0; q < 2; q++)
            sums[(i0 + q) & 3] = i0 + q < 4 ? _mm512_mul_pd(b->wc[i0 + q], rows[q])
                                            : _mm512_fmadd_pd(b->wc[i0 + q], rows[q], sums[(i0 + q) & 3]);
    }
    s[CREEP_OUT] = _mm512_add_pd(_mm512_add_pd(sums[0], sums[2]), _mm512_add_pd(sums[1], sums[3]));
}

/* one step of every channel; targets and out hold blocks x 8 entries */
static __attribute__((noinline)) void bank_step(bank *b, const double *targets, compensated *out) {
    /* the parameters and the state apart (restrict): no reloads after stores */
    long n = b->blocks;
    int cur = b->parity;
    /* up and down in turn, as mfcbeam's one-thread step: walked back, a
     * step starts on the lines the step before left in the cache */
    long first = cur ? n - 1 : 0, dir = cur ? -1 : 1;
    first_part(b, b->state + first * ROWS, targets + 8 * first, out + 8 * first, cur);
    for (long i = 0, k = first; i < n; i++, k += dir) {
        long next = k + dir;
        if (i + 1 < n)
            first_part(b, b->state + next * ROWS, targets + 8 * next, out + 8 * next, cur);
        creep_pass(b, b->state + k * ROWS);
    }
    b->parity ^= 1;
}

#ifdef PEER_LIB
/* For bank_limit: a bank of `channels` (a multiple of 8) channels of the
 * nominal model, limits +-1000 V. */
void *bank_new(long channels) {
    return channels > 0 && channels % 8 == 0 ? bank_create(channels) : NULL;
}

/* `steps` steps on the rows of `targets` (`rows` rows of the bank's
 * channels), row (k + 1) mod rows after row k; returns the sum of the
 * voltages of the last step */
double bank_run(void *p, const double *targets, long rows, long *k, long steps, void *out) {
    bank *b = p;
    long kk = *k;
    for (long i = 0; i < steps; i++) {
        kk = (kk + 1) % rows;
        bank_step(b, targets + kk * b->channels, out);
    }
    *k = kk;
    double sum = 0.0;
    for (long c = 0; c < b->channels; c++) sum += ((compensated *)out)[c].u;
    return sum;
}
#else
int main(int argc, char **argv) {
    long channels = argc == 3 && strcmp(argv[1], "steps") == 0 ? atol(argv[2]) : 0;
    if (!(argc == 2 && strcmp(argv[1], "trace") == 0) && !(channels > 0 && channels % 8 == 0)) {
        fprintf(stderr, "usage: %s trace | %s steps CHANNELS (a multiple of 8)\n", argv[0], argv[0]);
        return 2;
    }
    static double input[LEN], targets[LEN], row[8];
    static compensated out[8];
    test_input(input);
    model w;
    init_model(&w);
    for (int k = 0; k < LEN; k++) targets[k] = model_step(&w, input[k]);
    if (channels > 0) {
        bank *b = bank_create(channels);
        double *rows = malloc(sizeof(double) * (size_t)channels);
        compensated *outs = malloc(sizeof(compensated) * (size_t)channels);
        if (!b || !rows || !outs) return 1;
        double sum = 0.0;
        for (int k = 0; k < 200; k++) {
            for (long c = 0; c < channels; c++) rows[c] = targets[(16 * k + 37 * c) % LEN];
            bank_step(b, rows, outs);
            sum += outs[0].u;
        }
        printf("%.17g\n", sum);
        return 0;
    }
    bank *b = bank_create(8);
    if (!b) return 1;
    printf("y_d,u_peer\n");
    for (int k = 0; k < LEN; k++) {
        for (int l = 0; l < 8; l++) row[l] = targets[(k + 37 * l) % LEN];
        bank_step(b, row, out);
        printf("%.17g,%.17g\n", row[3], out[3].u);
    }
    return 0;
}
#endif
