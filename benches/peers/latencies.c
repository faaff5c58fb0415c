/* The latencies the step's dependency chain is made of, on the CPU that
 * runs this: each instruction in a dependent chain (its output its next
 * input), in core cycles, calibrated against a chain of integer adds (one
 * cycle each on every x86-64 core this project has met). Then how many
 * independent 512-bit operations of a kind, or of two kinds alternating,
 * the core starts per cycle: two kinds that share execution pipes start
 * no more together than one alone (the bank's bound rests on this). Used
 * for the latency bound and the bank's bound in the guide's performance
 * chapter. Needs AVX-512F:
 *
 *   cc -O2 -mavx512f -o latencies benches/peers/latencies.c && ./latencies
 */
#include <stdint.h>
#include <stdio.h>
#include <x86intrin.h>

#define N 100000000L

static double mem[8] __attribute__((aligned(64)));

static void int_adds(long n) {
    long x = 0;
    for (long i = 0; i < n; i++) __asm__ volatile("add $1, %0\n add $1, %0\n add $1, %0\n add $1, %0" : "+r"(x));
}

#define CHAIN(name, one)                                                              \
    static void name(long n) {                                                        \
        double *p = mem;                                                              \
        __asm__ volatile("vxorpd %%zmm0, %%zmm0, %%zmm0\n vxorpd %%zmm1, %%zmm1, %%zmm1" \
                         ::: "xmm0", "xmm1");                                          \
        for (long i = 0; i < n; i++)                                                  \
            __asm__ volatile(one one one one : : "r"(p) : "xmm0", "xmm1", "memory");  \
    }
CHAIN(addpd, "vaddpd %%zmm1, %%zmm0, %%zmm0\n")
CHAIN(addsd, "vaddsd %%xmm1, %%xmm0, %%xmm0\n")
CHAIN(minpd, "vminpd %%zmm1, %%zmm0, %%zmm0\n")
CHAIN(mulpd, "vmulpd %%zmm1, %%zmm0, %%zmm0\n")
CHAIN(broadcast, "vbroadcastsd %%xmm0, %%zmm0\n")
CHAIN(extract256, "vextractf64x4 $1, %%zmm0, %%ymm0\n")
CHAIN(extract128, "vextractf128 $1, %%ymm0, %%xmm0\n")
CHAIN(shuffle, "vshufpd $1, %%xmm0, %%xmm0, %%xmm0\n")
CHAIN(store_load, "vmovsd %%xmm0, 8(%0)\n vmovsd 8(%0), %%xmm0\n")

/* Twelve independent chains of `a` and `b` alternating, each op's
 * latency hidden by the other eleven: operations per cycle. */
#define RATE(name, a, b)                                                               \
    static void name(long n) {                                                         \
        __asm__ volatile("vxorpd %%zmm2, %%zmm2, %%zmm2\n" ::: "xmm2");                  \
        for (long i = 0; i < n; i++)                                                   \
            __asm__ volatile(a " %%zmm2, %%zmm3, %%zmm3\n" b " %%zmm2, %%zmm4, %%zmm4\n"   \
                             a " %%zmm2, %%zmm5, %%zmm5\n" b " %%zmm2, %%zmm6, %%zmm6\n"   \
                             a " %%zmm2, %%zmm7, %%zmm7\n" b " %%zmm2, %%zmm8, %%zmm8\n"   \
                             a " %%zmm2, %%zmm9, %%zmm9\n" b " %%zmm2, %%zmm10, %%zmm10\n" \
                             a " %%zmm2, %%zmm11, %%zmm11\n" b " %%zmm2, %%zmm12, %%zmm12\n" \
                             a " %%zmm2, %%zmm13, %%zmm13\n" b " %%zmm2, %%zmm14, %%zmm14\n" \
                             ::: "xmm3", "xmm4", "xmm5", "xmm6", "xmm7", "xmm8", "xmm9",     \
                               "xmm10", "xmm11", "xmm12", "xmm13", "xmm14");                 \
    }
RATE(rate_add, "vaddpd", "vaddpd")
RATE(rate_min, "vminpd", "vminpd")
RATE(rate_mul, "vmulpd", "vmulpd")
RATE(rate_add_min, "vaddpd", "vminpd")
RATE(rate_add_mul, "vaddpd", "vmulpd")
RATE(rate_min_mul, "vminpd", "vmulpd")

int main(void) {
    uint64_t t0 = __rdtsc();
    int_adds(N / 4);
    double tsc_per_cycle = (double)(__rdtsc() - t0) / N;
    struct { const char *name; void (*f)(long); } chains[] = {
        {"vaddpd zmm", addpd}, {"vaddsd", addsd}, {"vminpd zmm", minpd}, {"vmulpd zmm", mulpd},
        {"vbroadcastsd zmm, xmm", broadcast}, {"vextractf64x4", extract256},
        {"vextractf128", extract128}, {"vshufpd xmm", shuffle}, {"store, then load (sd)", store_load}};
    for (unsigned i = 0; i < sizeof chains / sizeof chains[0]; i++) {
        t0 = __rdtsc();
        chains[i].f(N / 4);
        printf("%-24s %5.2f cycles\n", chains[i].name, (double)(__rdtsc() - t0) / N / tsc_per_cycle);
    }
    struct { const char *name; void (*f)(long); } rates[] = {
        {"vaddpd", rate_add}, {"vminpd", rate_min}, {"vmulpd", rate_mul},
        {"vaddpd + vminpd", rate_add_min}, {"vaddpd + vmulpd", rate_add_mul},
        {"vminpd + vmulpd", rate_min_mul}};
    for (unsigned i = 0; i < sizeof rates / sizeof rates[0]; i++) {
        t0 = __rdtsc();
        rates[i].f(N / 12);
        printf("%-24s %5.2f per cycle (zmm)\n", rates[i].name,
               N / ((double)(__rdtsc() - t0) / tsc_per_cycle));
    }
    return 0;
}
