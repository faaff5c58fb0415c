/* The latencies the step's dependency chain is made of, on the CPU that
 * runs this: each instruction in a dependent chain (its output its next
 * input), in core cycles, calibrated against a chain of integer adds (one
 * cycle each on every x86-64 core this project has met). Used for the
 * latency bound in the guide's performance chapter. Needs AVX-512F:
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
    return 0;
}
