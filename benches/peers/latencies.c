/* The latencies the step's dependency chain is made of, on the CPU that
 * runs this: each instruction in a dependent chain (its output its next
 * input), in core cycles, calibrated against a chain of integer adds (one
 * cycle each on every x86-64 core this project has met); then pairs of
 * two kinds alternating in one chain, whose cycles exceed the two
 * latencies by what a result waits to pass between kinds of pipes (on a
 * Zen 5 about one where one of the two is an add). Then how many
 * independent 512-bit operations of a kind, or of two kinds alternating,
 * the core starts per cycle: two kinds that share execution pipes start
 * no more together than one alone (the bank's bound rests on this). Used
 * for the latency bound and the bank's bound in the guide's performance
 * chapter. On 512-bit registers where the compiler targets AVX-512F, on
 * 256-bit ones otherwise (AVX2 and FMA needed):
 *
 *   cc -O2 -march=native -o latencies benches/peers/latencies.c && ./latencies
 */
#include <stdint.h>
#include <stdio.h>
#include <x86intrin.h>

#define N 100000000L

/* the widest registers the kernels use here */
#ifdef __AVX512F__
#define W "zmm"
#else
#define W "ymm"
#endif

static double mem[8] __attribute__((aligned(64)));

/* the added one comes from a register: a Golden Cove core (Sapphire
 * Rapids) folds a chain of immediate adds in its renamer, about four a
 * cycle, which would read as a clock four times too slow */
static void int_adds(long n) {
    long x = 0, one = 1;
    for (long i = 0; i < n; i++)
        __asm__ volatile("add %1, %0\n add %1, %0\n add %1, %0\n add %1, %0" : "+r"(x) : "r"(one));
}

#define CHAIN(name, one)                                                              \
    static void name(long n) {                                                        \
        double *p = mem;                                                              \
        __asm__ volatile("vxorpd %%" W "0, %%" W "0, %%" W "0\n"                    \
                         "vxorpd %%" W "1, %%" W "1, %%" W "1" ::: "xmm0", "xmm1");    \
        for (long i = 0; i < n; i++)                                                  \
            __asm__ volatile(one one one one : : "r"(p) : "xmm0", "xmm1", "memory");  \
    }
CHAIN(addpd, "vaddpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(addsd, "vaddsd %%xmm1, %%xmm0, %%xmm0\n")
CHAIN(minpd, "vminpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(mulpd, "vmulpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(fmapd, "vfmadd231pd %%" W "1, %%" W "1, %%" W "0\n")
CHAIN(broadcast, "vbroadcastsd %%xmm0, %%" W "0\n")
#ifdef __AVX512F__
CHAIN(extract256, "vextractf64x4 $1, %%zmm0, %%ymm0\n")
#endif
CHAIN(extract128, "vextractf128 $1, %%ymm0, %%xmm0\n")
CHAIN(shuffle, "vshufpd $1, %%xmm0, %%xmm0, %%xmm0\n")
/* the butterfly's swap of 128-bit halves, and the f32 sum's lane swap */
CHAIN(perm2f128, "vperm2f128 $1, %%ymm0, %%ymm0, %%ymm0\n")
CHAIN(movshdup, "vmovshdup %%xmm0, %%xmm0\n")
CHAIN(broadcastss, "vbroadcastss %%xmm0, %%ymm0\n")
CHAIN(store_load, "vmovsd %%xmm0, 8(%0)\n vmovsd 8(%0), %%xmm0\n")

/* Two kinds alternating in one chain: their latencies, plus what a result
 * waits to pass from one kind of pipe to the other and back (on a Zen 5
 * about a cycle a pair where one of the two is an add) */
CHAIN(pair_add_min, "vaddpd %%" W "1, %%" W "0, %%" W "0\n vminpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(pair_add_mul, "vaddpd %%" W "1, %%" W "0, %%" W "0\n vmulpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(pair_fma_add, "vfmadd231pd %%" W "1, %%" W "1, %%" W "0\n vaddpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(pair_min_max, "vminpd %%" W "1, %%" W "0, %%" W "0\n vmaxpd %%" W "1, %%" W "0, %%" W "0\n")
CHAIN(pair_max_fma, "vmaxpd %%" W "1, %%" W "0, %%" W "0\n vfmadd231pd %%" W "1, %%" W "1, %%" W "0\n")
CHAIN(pair_perm_add, "vperm2f128 $1, %%ymm0, %%ymm0, %%ymm0\n vaddpd %%ymm1, %%ymm0, %%ymm0\n")

/* Twelve independent chains of `a` and `b` alternating, each op's
 * latency hidden by the other eleven: operations per cycle. */
#define RATE(name, a, b)                                                               \
    static void name(long n) {                                                         \
        __asm__ volatile("vxorpd %%" W "2, %%" W "2, %%" W "2\n" ::: "xmm2");         \
        for (long i = 0; i < n; i++)                                                   \
            __asm__ volatile(a " %%" W "2, %%" W "3, %%" W "3\n"                         \
                             b " %%" W "2, %%" W "4, %%" W "4\n"                         \
                             a " %%" W "2, %%" W "5, %%" W "5\n"                         \
                             b " %%" W "2, %%" W "6, %%" W "6\n"                         \
                             a " %%" W "2, %%" W "7, %%" W "7\n"                         \
                             b " %%" W "2, %%" W "8, %%" W "8\n"                         \
                             a " %%" W "2, %%" W "9, %%" W "9\n"                         \
                             b " %%" W "2, %%" W "10, %%" W "10\n"                       \
                             a " %%" W "2, %%" W "11, %%" W "11\n"                       \
                             b " %%" W "2, %%" W "12, %%" W "12\n"                       \
                             a " %%" W "2, %%" W "13, %%" W "13\n"                       \
                             b " %%" W "2, %%" W "14, %%" W "14\n"                       \
                             ::: "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9",     \
                               "xmm10", "xmm11", "xmm12", "xmm13", "xmm14");                 \
    }
RATE(rate_add, "vaddpd", "vaddpd")
RATE(rate_min, "vminpd", "vminpd")
RATE(rate_mul, "vmulpd", "vmulpd")
RATE(rate_add_min, "vaddpd", "vminpd")
RATE(rate_add_mul, "vaddpd", "vmulpd")
RATE(rate_min_mul, "vminpd", "vmulpd")
RATE(rate_fma, "vfmadd231pd", "vfmadd231pd")
RATE(rate_add_fma, "vaddpd", "vfmadd231pd")
RATE(rate_min_fma, "vminpd", "vfmadd231pd")

int main(void) {
    uint64_t t0 = __rdtsc();
    int_adds(N / 4);
    double tsc_per_cycle = (double)(__rdtsc() - t0) / N;
    struct { const char *name; void (*f)(long); } chains[] = {
        {"vaddpd " W, addpd}, {"vaddsd", addsd}, {"vminpd " W, minpd}, {"vmulpd " W, mulpd},
        {"vfmadd231pd " W, fmapd}, {"vbroadcastsd " W ", xmm", broadcast},
#ifdef __AVX512F__
        {"vextractf64x4", extract256},
#endif
        {"vextractf128", extract128}, {"vshufpd xmm", shuffle}, {"vperm2f128 ymm", perm2f128},
        {"vmovshdup xmm", movshdup}, {"vbroadcastss ymm, xmm", broadcastss},
        {"store, then load (sd)", store_load},
        {"vaddpd + vminpd, a pair", pair_add_min}, {"vaddpd + vmulpd, a pair", pair_add_mul},
        {"vfmadd231pd + vaddpd, a pair", pair_fma_add}, {"vminpd + vmaxpd, a pair", pair_min_max},
        {"vmaxpd + vfmadd231pd, a pair", pair_max_fma}, {"vperm2f128 + vaddpd, a pair", pair_perm_add}};
    for (unsigned i = 0; i < sizeof chains / sizeof chains[0]; i++) {
        t0 = __rdtsc();
        chains[i].f(N / 4);
        printf("%-29s %5.2f cycles\n", chains[i].name, (double)(__rdtsc() - t0) / N / tsc_per_cycle);
    }
    struct { const char *name; void (*f)(long); } rates[] = {
        {"vaddpd", rate_add}, {"vminpd", rate_min}, {"vmulpd", rate_mul},
        {"vaddpd + vminpd", rate_add_min}, {"vaddpd + vmulpd", rate_add_mul},
        {"vminpd + vmulpd", rate_min_mul}, {"vfmadd231pd", rate_fma},
        {"vaddpd + vfmadd231pd", rate_add_fma}, {"vminpd + vfmadd231pd", rate_min_fma}};
    for (unsigned i = 0; i < sizeof rates / sizeof rates[0]; i++) {
        t0 = __rdtsc();
        rates[i].f(N / 12);
        printf("%-24s %5.2f per cycle (" W ")\n", rates[i].name,
               N / ((double)(__rdtsc() - t0) / tsc_per_cycle));
    }
    return 0;
}
