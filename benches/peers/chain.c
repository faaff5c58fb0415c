/* The compensator step's dependency chain alone, on the CPU that runs
 * this: the instructions from the creep's output C_k to C_{k+1} that wait
 * for each other, in a loop with nothing else, written in assembly as the
 * kernels issue them (the paper's layout: twelve plays, twelve creep
 * thresholds, five rows), and the cycles one trip takes. It counts what an
 * instruction table misses: the cycles a result waits to pass between the
 * core's kinds of pipes (on a Zen 5 about one each time an add's result
 * feeds another kind of operation or takes another's, which the chain does
 * some seven times). Printed for
 *  - mfcbeam's f64 step on the AVX-512 set: H^-1 on three 4-lane blocks,
 *    the creep pass on an 8-lane and a 4-lane block;
 *  - the same with H^-1 on an 8-lane and a 4-lane block too (the set's
 *    step before 2026-12);
 *  - mfcbeam's f64 step on the AVX2 set: both on three 4-lane blocks;
 *  - the strongest C peer's (compensator.c, -DSTRONG): only the creep
 *    increment on the chain, every sum a tree;
 * each a run (C in a register) and one call (C stored by a step and loaded
 * by the next one's broadcast), the best of seven trips, each timed between
 * two readings of the clock (a chain of integer adds). A step cannot be faster than its chain;
 * the peers bench shows how close it comes.
 *
 *   cc -O2 -march=native -o chain benches/peers/chain.c && ./chain
 *
 * Needs AVX-512F (the 8-lane blocks); the values are zeros throughout
 * (the latencies do not depend on them).
 */
#include <stdint.h>
#include <stdio.h>
#include <x86intrin.h>

#define N 2000000L

static double slot[8] __attribute__((aligned(64)));

/* the added one comes from a register: a Golden Cove core (Sapphire
 * Rapids) folds a chain of immediate adds in its renamer, about four a
 * cycle, which would read as a clock four times too slow */
static void int_adds(long n) {
    long x = 0, one = 1;
    for (long i = 0; i < n; i++)
        __asm__ volatile("add %1, %0\n add %1, %0\n add %1, %0\n add %1, %0" : "+r"(x) : "r"(one));
}

/* C in ymm6 (every lane) at the top, C_{k+1} in ymm6 at the bottom;
 * zmm10-zmm12 stand for the parameters and states (read, never written) */
#define TRIP(name, body)                                                                      \
    static double name(void) {                                                                \
        __asm__ volatile("vxorpd %%zmm6, %%zmm6, %%zmm6\n vxorpd %%zmm10, %%zmm10, %%zmm10\n" \
                         "vxorpd %%zmm11, %%zmm11, %%zmm11\n vxorpd %%zmm12, %%zmm12, %%zmm12" \
                         ::: "xmm6", "xmm10", "xmm11", "xmm12");                               \
        uint64_t t0 = __rdtsc();                                                              \
        for (long i = 0; i < N; i++)                                                          \
            __asm__ volatile(body :: "r"(slot) : "xmm0", "xmm1", "xmm2", "xmm3", "xmm4",      \
                             "xmm5", "xmm6", "xmm7", "xmm8", "xmm9", "xmm13", "xmm14",        \
                             "xmm15", "memory");                                              \
        return (double)(__rdtsc() - t0) / N;                                                  \
    }

/* sum of four partial sums in every lane (four::all_lanes_sum) */
#define BUTTERFLY(r)                                                     \
    "vperm2f128 $1, %%ymm" r ", %%ymm" r ", %%ymm1\n"                    \
    "vaddpd %%ymm1, %%ymm" r ", %%ymm" r "\n"                            \
    "vshufpd $5, %%ymm" r ", %%ymm" r ", %%ymm1\n"                       \
    "vaddpd %%ymm1, %%ymm" r ", %%ymm" r "\n"
/* H^-1's block of four plays from C (ymm6): (t -+ r) - C, the clamp */
#define PLAYS4(dst)                                                      \
    "vsubpd %%ymm6, %%ymm10, %%ymm4\n vsubpd %%ymm6, %%ymm11, %%ymm5\n"  \
    "vminpd %%ymm4, %%ymm12, %%ymm3\n vmaxpd %%ymm5, %%ymm3, %%ymm" dst "\n"
/* three blocks of four, their weighted sum (a product, two fused) */
#define HINV_FOUR                                                        \
    PLAYS4("0") "vmulpd %%ymm10, %%ymm0, %%ymm0\n"                       \
    PLAYS4("2") "vfmadd231pd %%ymm12, %%ymm2, %%ymm0\n"                  \
    PLAYS4("2") "vfmadd231pd %%ymm12, %%ymm2, %%ymm0\n" BUTTERFLY("0")
/* an 8-lane block (C broadcast to 8 lanes, the sum's upper half
 * extracted) and a 4-lane one */
#define HINV_EIGHT                                                       \
    "vbroadcastsd %%xmm6, %%zmm1\n"                                      \
    "vsubpd %%zmm1, %%zmm10, %%zmm4\n vsubpd %%zmm1, %%zmm11, %%zmm5\n"  \
    "vminpd %%zmm4, %%zmm12, %%zmm3\n vmaxpd %%zmm5, %%zmm3, %%zmm0\n"   \
    "vextractf64x4 $1, %%zmm0, %%ymm1\n vmulpd %%ymm10, %%ymm0, %%ymm0\n" \
    "vfmadd231pd %%ymm11, %%ymm1, %%ymm0\n"                              \
    PLAYS4("2") "vfmadd231pd %%ymm12, %%ymm2, %%ymm0\n" BUTTERFLY("0")
/* one creep row of a block: the clamp to the bounds (1: upper, 3: lower),
 * the update g c + (x - g x) into r */
#define ROW(w, r)                                                        \
    "vminpd %%" w "1, %%" w "12, %%" w "7\n vmaxpd %%" w "3, %%" w "7, %%" w "7\n" \
    "vmovapd %%" w "11, %%" w r "\n vfmadd231pd %%" w "7, %%" w "10, %%" w r "\n"
#define ADD(w, a, b) "vaddpd %%" w b ", %%" w a ", %%" w a "\n"
/* a block's five rows from u (in w0), summed in order into dst */
#define ROWS(w, dst)                                                     \
    "vsubpd %%" w "10, %%" w "0, %%" w "3\n vaddpd %%" w "10, %%" w "0, %%" w "1\n" \
    ROW(w, dst) ROW(w, "8") ADD(w, dst, "8") ROW(w, "8") ADD(w, dst, "8")  \
    ROW(w, "8") ADD(w, dst, "8") ROW(w, "8") ADD(w, dst, "8")
/* the creep pass on three blocks of four */
#define CREEP_FOUR                                                       \
    ROWS("ymm", "2") "vmulpd %%ymm10, %%ymm2, %%ymm6\n"                  \
    ROWS("ymm", "2") "vfmadd231pd %%ymm12, %%ymm2, %%ymm6\n"             \
    ROWS("ymm", "2") "vfmadd231pd %%ymm12, %%ymm2, %%ymm6\n" BUTTERFLY("6")
/* on an 8-lane block (u broadcast to 8 lanes) and a 4-lane one */
#define CREEP_EIGHT                                                      \
    "vbroadcastsd %%xmm0, %%zmm0\n" ROWS("zmm", "2")                     \
    "vextractf64x4 $1, %%zmm2, %%ymm1\n vmulpd %%ymm10, %%ymm2, %%ymm2\n" \
    "vfmadd231pd %%ymm11, %%ymm1, %%ymm2\n"                              \
    ROWS("ymm", "6") "vfmadd231pd %%ymm12, %%ymm6, %%ymm2\n" BUTTERFLY("2") \
    "vmovapd %%ymm2, %%ymm6\n"
/* the strongest C: its H^-1 (the bounds less dC, three products, a tree)
 * and its creep increment (15 groups of four: clamp, q c - q x, a tree of
 * depth four) */
#define STRONG_PLAYS(dst)                                                \
    "vsubpd %%ymm6, %%ymm10, %%ymm4\n vsubpd %%ymm6, %%ymm11, %%ymm5\n"  \
    "vminpd %%ymm4, %%ymm12, %%ymm3\n vmaxpd %%ymm5, %%ymm3, %%ymm3\n"   \
    "vmulpd %%ymm10, %%ymm3, %%ymm" dst "\n"
#define STRONG_GROUP(dst)                                                \
    "vminpd %%ymm1, %%ymm12, %%ymm7\n vmaxpd %%ymm3, %%ymm7, %%ymm7\n"   \
    "vfmsub213pd %%ymm11, %%ymm10, %%ymm7\n vmovapd %%ymm7, %%ymm" dst "\n"
#define STRONG                                                           \
    STRONG_PLAYS("0") STRONG_PLAYS("2") STRONG_PLAYS("8")                \
    ADD("ymm", "0", "8") ADD("ymm", "0", "2") BUTTERFLY("0")             \
    "vsubpd %%ymm10, %%ymm0, %%ymm3\n vaddpd %%ymm10, %%ymm0, %%ymm1\n"  \
    STRONG_GROUP("2") STRONG_GROUP("8") STRONG_GROUP("9") STRONG_GROUP("13") \
    STRONG_GROUP("14") STRONG_GROUP("15") STRONG_GROUP("4")              \
    ADD("ymm", "2", "8") ADD("ymm", "9", "13") ADD("ymm", "14", "15")    \
    ADD("ymm", "2", "9") ADD("ymm", "14", "4") ADD("ymm", "2", "14")     \
    STRONG_GROUP("8") STRONG_GROUP("9") STRONG_GROUP("13") STRONG_GROUP("15") \
    ADD("ymm", "8", "9") ADD("ymm", "13", "15") ADD("ymm", "8", "13")    \
    STRONG_GROUP("9") STRONG_GROUP("13") STRONG_GROUP("15") STRONG_GROUP("4") \
    ADD("ymm", "9", "13") ADD("ymm", "15", "4") ADD("ymm", "9", "15")    \
    ADD("ymm", "8", "9") ADD("ymm", "2", "8") BUTTERFLY("2") "vmovapd %%ymm2, %%ymm6\n"
/* one call: C stored at a step's end, read by the next one's broadcast */
#define CALL(body) "vbroadcastsd (%0), %%ymm6\n" body "vmovsd %%xmm6, (%0)\n"

TRIP(avx512_run, HINV_FOUR CREEP_EIGHT)
TRIP(avx512_call, CALL(HINV_FOUR CREEP_EIGHT))
TRIP(avx512_eight_run, HINV_EIGHT CREEP_EIGHT)
TRIP(avx2_run, HINV_FOUR CREEP_FOUR)
TRIP(avx2_call, CALL(HINV_FOUR CREEP_FOUR))
TRIP(strong_run, STRONG)
TRIP(strong_call, CALL(STRONG))

/* TSC ticks per core cycle now, by a chain of integer adds (one cycle
 * each): taken beside every trip, as the clock moves */
static double tsc_per_cycle(void) {
    uint64_t t0 = __rdtsc();
    int_adds(N);
    return (double)(__rdtsc() - t0) / (4.0 * N);
}

int main(void) {
    struct { const char *name; double (*f)(void); } trips[] = {
        {"f64, AVX-512 set, a run", avx512_run},
        {"f64, AVX-512 set, one call", avx512_call},
        {"f64, AVX-512 set with H^-1 on 8 lanes, a run", avx512_eight_run},
        {"f64, AVX2 set, a run", avx2_run},
        {"f64, AVX2 set, one call", avx2_call},
        {"the strongest C, a run", strong_run},
        {"the strongest C, one call", strong_call}};
    for (unsigned i = 0; i < sizeof trips / sizeof trips[0]; i++) {
        double best = 1e30;
        for (int k = 0; k < 7; k++) {
            double before = tsc_per_cycle();
            double ticks = trips[i].f();
            double c = ticks / (0.5 * (before + tsc_per_cycle()));
            if (c < best) best = c;
        }
        printf("%-46s %6.1f cycles (the best of seven)\n", trips[i].name, best);
    }
    return 0;
}
