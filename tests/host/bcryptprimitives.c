/* A stand-in for Windows' bcryptprimitives.dll, for running the project's Windows library under
 * wine 8 only (Windows 10 and later have the real one). Rust's standard library for Windows
 * imports one function from it, ProcessPrng, which wine 8 lacks; this one fills the buffer
 * from advapi32's RtlGenRandom (exported as SystemFunction036). The test copies the built DLL
 * beside the host's .exe, where the loader looks first. */
#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x10000000 ? 0x10000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk))
            return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
