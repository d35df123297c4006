/* A minimal FMI 3.0 Co-Simulation host of the project's own, built for linux64 (gcc) and
 * win64 (MinGW-w64, run under wine) by tests/python/test_fmi3_windows.py, so that the two
 * libraries of an FMI 3.0 FMU run the same experiment and their transcripts can be compared.
 *
 *   fmi3_host LIBRARY RESOURCE_PATH TOKEN STOP STEP EARLY VR,VR,...
 *
 * Instantiates Co-Simulation (earlyReturnAllowed = EARLY, 0 or 1), initialises with the stop
 * time, steps to every multiple of STEP up to STOP, going on from every early return, and
 * prints one line per early return ("early T") and per communication point ("point T X X
 * ...": the Float64 variables VR,VR,... there), every number as a C99 hexadecimal float, then
 * "done". The declarations below are this host's own, after the FMI 3.0 standard. */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#define LOAD(path) ((void *)LoadLibraryA(path))
#define SYMBOL(lib, name) ((void *)GetProcAddress((HMODULE)(lib), name))
#else
#include <dlfcn.h>
#define LOAD(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define SYMBOL(lib, name) dlsym(lib, name)
#endif

typedef void *Instance;
typedef void (*LogMessage)(void *env, int status, const char *category, const char *message);
typedef Instance (*InstantiateCS)(const char *, const char *, const char *, bool, bool, bool, bool,
                                  const uint32_t *, size_t, void *, LogMessage, void *);
typedef int (*EnterInit)(Instance, bool, double, double, bool, double);
typedef int (*OneArg)(Instance);
typedef int (*DoStep)(Instance, double, double, bool, bool *, bool *, bool *, double *);
typedef int (*GetFloat64)(Instance, const uint32_t *, size_t, double *, size_t);
typedef void (*FreeInstance)(Instance);

static void logger(void *env, int status, const char *category, const char *message) {
    (void)env;
    fprintf(stderr, "log %d %s: %s\n", status, category, message);
}

static void *need(void *lib, const char *name) {
    void *f = SYMBOL(lib, name);
    if (!f) {
        fprintf(stderr, "missing %s\n", name);
        exit(3);
    }
    return f;
}

int main(int argc, char **argv) {
    if (argc != 8) {
        fprintf(stderr, "usage: fmi3_host LIBRARY RESOURCE_PATH TOKEN STOP STEP EARLY VR,VR,...\n");
        return 2;
    }
    void *lib = LOAD(argv[1]);
    if (!lib) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 3;
    }
    double stop = strtod(argv[4], NULL), step = strtod(argv[5], NULL);
    bool early = atoi(argv[6]) != 0;
    uint32_t vrs[1024];
    size_t n = 0;
    for (char *p = strtok(argv[7], ","); p && n < 1024; p = strtok(NULL, ",")) vrs[n++] = (uint32_t)strtoul(p, NULL, 10);
    double values[1024];

    InstantiateCS instantiate = (InstantiateCS)need(lib, "fmi3InstantiateCoSimulation");
    EnterInit enter = (EnterInit)need(lib, "fmi3EnterInitializationMode");
    OneArg exit_init = (OneArg)need(lib, "fmi3ExitInitializationMode");
    OneArg terminate = (OneArg)need(lib, "fmi3Terminate");
    DoStep do_step = (DoStep)need(lib, "fmi3DoStep");
    GetFloat64 get = (GetFloat64)need(lib, "fmi3GetFloat64");
    FreeInstance free_instance = (FreeInstance)need(lib, "fmi3FreeInstance");

    Instance c = instantiate("host", argv[3], argv[2], false, false, false, early, NULL, 0, NULL, logger, NULL);
    if (!c) {
        printf("instantiate failed\n");
        return 1;
    }
    if (enter(c, false, 0.0, 0.0, true, stop) != 0 || exit_init(c) != 0) {
        printf("initialisation failed\n");
        return 1;
    }
    long points = (long)(stop / step + 0.5);
    double t = 0.0;
    for (long k = 1; k <= points;) {
        double target = k == points ? stop : (double)k * step;
        bool event = false, terminated = false, returned = false;
        double last = 0.0;
        int status = do_step(c, t, target - t, true, &event, &terminated, &returned, &last);
        if (status != 0) {
            printf("step from %a failed with status %d\n", t, status);
            return 1;
        }
        t = last;
        if (returned) {
            printf("early %a\n", t);
            continue;
        }
        if (get(c, vrs, n, values, n) != 0) {
            printf("read at %a failed\n", t);
            return 1;
        }
        printf("point %a", t);
        for (size_t i = 0; i < n; i++) printf(" %a", values[i]);
        printf("\n");
        k++;
    }
    terminate(c);
    free_instance(c);
    printf("done\n");
    return 0;
}
