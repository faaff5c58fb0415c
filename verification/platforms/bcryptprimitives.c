/*
 * A stand-in for Windows 10's bcryptprimitives.dll, for wine 8.0 (Debian
 * 12), which lacks it: Rust's standard library takes its random seeds from
 * ProcessPrng there, so every Rust DLL imports it. Only the check's wine
 * prefix gets this file; Windows 10 and 11 have the real one.
 *
 *     x86_64-w64-mingw32-gcc -shared -o bcryptprimitives.dll \
 *         bcryptprimitives.c -ladvapi32
 */
#include <windows.h>

/* RtlGenRandom, exported by advapi32 as SystemFunction036 */
BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x10000000 ? 0x10000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk)) return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
