/* fmi_host: a small FMI 2.0 Co-Simulation host of the project's own, built natively for Linux
 * (gcc) and for 64-bit Windows (x86_64-w64-mingw32-gcc, run under wine), so that both platform
 * libraries of an FMU run the same calls and their transcripts can be compared line by line.
 *
 *   fmi_host LIBRARY SCRIPT      (SCRIPT "-" reads standard input)
 *
 * The script is one call per line; `#` starts a comment; "..." is one token, spaces included. Every call prints one line to standard
 * output: the command, its status and the values it read (reals as C99 hexadecimal floats, so
 * that a comparison is exact). Log messages go to standard error with their status and category;
 * standard output gets only `log <status> <category>` (the texts name paths, which differ).
 *
 * Commands (I: an instance slot 0..15, S: a state slot 0..15, VR: value references):
 *   instantiate I NAME GUID URI CALLBACKS LOGGING   CALLBACKS: logger | silent | null; NAME,
 *                                     GUID and URI may be NULL; URI @PATH is the file URI of
 *                                     PATH as this process sees it (a Windows process: file:///Z:/...)
 *   garbage I HEX                     slot I holds a handle that no instantiate returned
 *   free I | enter I | exit I | terminate I | reset I | cancel I
 *   setup I TOL_DEFINED TOL START STOP_DEFINED STOP
 *   debug I ON NCATEGORIES [CATEGORY ...]
 *   set_real I VR VALUE [VR VALUE ...]      (VALUE: strtod, so nan, inf, 0x1p-3 work)
 *   get_real I VR ...                  get_integer I VR ...    get_boolean I VR ...
 *   set_integer I VR VALUE [...]       set_boolean I VR VALUE [...]
 *   get_string I VR ...                set_string I VR TEXT [...]
 *   get_real_null I N                  fmi2GetReal with NULL arrays and N values
 *   dostep I T H NEW_STEP
 *   run I H FROM TO VR ...             the communication points k*H for k = FROM..TO: the VR's
 *                                      read at FROM, then a step of H to each next point and a
 *                                      read there (`point K STATUS VALUES`); stops at a non-OK status
 *   get_state I S | set_state I S | free_state I S | garbage_state S HEX
 *   serialize I S FILE                 writes the serialized state of slot S to FILE
 *   deserialize I FILE S               reads FILE into slot S
 *   status I KIND                      fmi2GetStatus/RealStatus/BooleanStatus for KIND 0..3
 *   version | platform | echo TEXT
 */
#define _CRT_SECURE_NO_WARNINGS
#define _XOPEN_SOURCE 700
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#include <limits.h>
#endif

/* FMI 2.0 types (fmi2TypesPlatform.h, fmi2FunctionTypes.h) */
typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef int fmi2Status;
typedef int fmi2Type;
typedef int fmi2StatusKind;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef void *(*fmi2CallbackAllocateMemory)(size_t, size_t);
typedef void (*fmi2CallbackFreeMemory)(void *);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment, fmi2Status);
typedef struct {
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocateMemory;
    fmi2CallbackFreeMemory freeMemory;
    fmi2StepFinished stepFinished;
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef const char *(*GetStringFn)(void);
typedef fmi2Component (*InstantiateFn)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions *,
                                       fmi2Boolean, fmi2Boolean);
typedef void (*FreeInstanceFn)(fmi2Component);
typedef fmi2Status (*SetDebugLoggingFn)(fmi2Component, fmi2Boolean, size_t, const fmi2String[]);
typedef fmi2Status (*SetupFn)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*ComponentFn)(fmi2Component);
typedef fmi2Status (*GetRealFn)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[]);
typedef fmi2Status (*GetIntegerFn)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Integer[]);
typedef fmi2Status (*GetStringFn2)(fmi2Component, const fmi2ValueReference[], size_t, fmi2String[]);
typedef fmi2Status (*SetRealFn)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Real[]);
typedef fmi2Status (*SetIntegerFn)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Integer[]);
typedef fmi2Status (*SetStringFn)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2String[]);
typedef fmi2Status (*GetStateFn)(fmi2Component, fmi2FMUstate *);
typedef fmi2Status (*SetStateFn)(fmi2Component, fmi2FMUstate);
typedef fmi2Status (*StateSizeFn)(fmi2Component, fmi2FMUstate, size_t *);
typedef fmi2Status (*SerializeFn)(fmi2Component, fmi2FMUstate, fmi2Byte[], size_t);
typedef fmi2Status (*DeserializeFn)(fmi2Component, const fmi2Byte[], size_t, fmi2FMUstate *);
typedef fmi2Status (*DoStepFn)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef fmi2Status (*StatusFn)(fmi2Component, fmi2StatusKind, fmi2Status *);
typedef fmi2Status (*RealStatusFn)(fmi2Component, fmi2StatusKind, fmi2Real *);
typedef fmi2Status (*BooleanStatusFn)(fmi2Component, fmi2StatusKind, fmi2Boolean *);

static struct {
    GetStringFn GetTypesPlatform, GetVersion;
    InstantiateFn Instantiate;
    FreeInstanceFn FreeInstance;
    SetDebugLoggingFn SetDebugLogging;
    SetupFn SetupExperiment;
    ComponentFn EnterInitializationMode, ExitInitializationMode, Terminate, Reset, CancelStep;
    GetRealFn GetReal;
    GetIntegerFn GetInteger, GetBoolean;
    GetStringFn2 GetString;
    SetRealFn SetReal;
    SetIntegerFn SetInteger, SetBoolean;
    SetStringFn SetString;
    GetStateFn GetFMUstate, FreeFMUstate;
    SetStateFn SetFMUstate;
    StateSizeFn SerializedFMUstateSize;
    SerializeFn SerializeFMUstate;
    DeserializeFn DeSerializeFMUstate;
    DoStepFn DoStep;
    StatusFn GetStatus;
    RealStatusFn GetRealStatus;
    BooleanStatusFn GetBooleanStatus;
} fmi;

#define SLOTS 16
#define MAX_VALUES 4096
static fmi2Component instances[SLOTS];
static fmi2FMUstate states[SLOTS];
static int line_number;

static void fail(const char *what) {
    fprintf(stderr, "fmi_host: line %d: %s\n", line_number, what);
    exit(2);
}

static void *symbol(void *library, const char *name) {
#ifdef _WIN32
    void *p = (void *)GetProcAddress((HMODULE)library, name);
#else
    void *p = dlsym(library, name);
#endif
    if (!p) {
        fprintf(stderr, "fmi_host: the library has no %s\n", name);
        exit(2);
    }
    return p;
}

static void load(const char *path) {
#ifdef _WIN32
    void *library = (void *)LoadLibraryA(path);
    if (!library) {
        fprintf(stderr, "fmi_host: cannot load %s (error %lu)\n", path, (unsigned long)GetLastError());
        exit(2);
    }
#else
    void *library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        fprintf(stderr, "fmi_host: cannot load %s: %s\n", path, dlerror());
        exit(2);
    }
#endif
#define BIND(field, name) *(void **)&fmi.field = symbol(library, name)
    BIND(GetTypesPlatform, "fmi2GetTypesPlatform");
    BIND(GetVersion, "fmi2GetVersion");
    BIND(Instantiate, "fmi2Instantiate");
    BIND(FreeInstance, "fmi2FreeInstance");
    BIND(SetDebugLogging, "fmi2SetDebugLogging");
    BIND(SetupExperiment, "fmi2SetupExperiment");
    BIND(EnterInitializationMode, "fmi2EnterInitializationMode");
    BIND(ExitInitializationMode, "fmi2ExitInitializationMode");
    BIND(Terminate, "fmi2Terminate");
    BIND(Reset, "fmi2Reset");
    BIND(CancelStep, "fmi2CancelStep");
    BIND(GetReal, "fmi2GetReal");
    BIND(GetInteger, "fmi2GetInteger");
    BIND(GetBoolean, "fmi2GetBoolean");
    BIND(GetString, "fmi2GetString");
    BIND(SetReal, "fmi2SetReal");
    BIND(SetInteger, "fmi2SetInteger");
    BIND(SetBoolean, "fmi2SetBoolean");
    BIND(SetString, "fmi2SetString");
    BIND(GetFMUstate, "fmi2GetFMUstate");
    BIND(SetFMUstate, "fmi2SetFMUstate");
    BIND(FreeFMUstate, "fmi2FreeFMUstate");
    BIND(SerializedFMUstateSize, "fmi2SerializedFMUstateSize");
    BIND(SerializeFMUstate, "fmi2SerializeFMUstate");
    BIND(DeSerializeFMUstate, "fmi2DeSerializeFMUstate");
    BIND(DoStep, "fmi2DoStep");
    BIND(GetStatus, "fmi2GetStatus");
    BIND(GetRealStatus, "fmi2GetRealStatus");
    BIND(GetBooleanStatus, "fmi2GetBooleanStatus");
#undef BIND
}

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    char text[4096];
    va_list args;
    (void)env;
    va_start(args, message);
    vsnprintf(text, sizeof text, message ? message : "(null)", args);
    va_end(args);
    printf("log %d %s\n", status, category ? category : "(null)");
    fprintf(stderr, "[%s] %d %s: %s\n", name ? name : "(null)", status, category ? category : "(null)", text);
}

static fmi2CallbackFunctions with_logger = {logger, calloc, free, NULL, NULL};
static fmi2CallbackFunctions silent = {NULL, NULL, NULL, NULL, NULL};

/* The tokens of one line. */
static char *tokens[2 * MAX_VALUES + 8];
static int ntokens;

static void split(char *line) {
    char *p = line;
    ntokens = 0;
    for (;;) {
        while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')
            p++;
        if (!*p || *p == '#')
            break;
        if (ntokens == (int)(sizeof tokens / sizeof tokens[0]))
            fail("too many tokens");
        if (*p == '"') {
            /* a quoted token: everything up to the next quote, spaces included */
            tokens[ntokens++] = ++p;
            while (*p && *p != '"')
                p++;
            if (!*p)
                fail("unterminated quote");
            *p++ = 0;
            continue;
        }
        tokens[ntokens++] = p;
        while (*p && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\n')
            p++;
        if (*p)
            *p++ = 0;
    }
}

static const char *arg(int i) {
    if (i >= ntokens)
        fail("missing argument");
    return tokens[i];
}

static long integer_arg(int i) {
    char *end;
    long v = strtol(arg(i), &end, 0);
    if (*end)
        fail("not an integer");
    return v;
}

static double real_arg(int i) {
    char *end;
    double v = strtod(arg(i), &end);
    if (*end)
        fail("not a number");
    return v;
}

static int slot(int i) {
    long s = integer_arg(i);
    if (s < 0 || s >= SLOTS)
        fail("slot out of range");
    return (int)s;
}

/* NULL stands for a null pointer ("" is the empty string, "a b" a string with a space). */
static const char *string_arg(int i) {
    const char *s = arg(i);
    if (!strcmp(s, "NULL"))
        return NULL;
    return s;
}

/* The file URI of PATH as this process sees it: an absolute path, '/'-separated, percent-encoded
 * (a Windows path X:\a b -> file:///X:/a%20b). */
static void file_uri(const char *path, char *out, size_t size) {
    char full[4096];
    size_t n = 0;
    const unsigned char *p;
#ifdef _WIN32
    if (!GetFullPathNameA(path, sizeof full, full, NULL))
        fail("GetFullPathName failed");
#else
    if (!realpath(path, full))
        fail("realpath failed");
#endif
    n += (size_t)snprintf(out, size, "file://%s", full[0] == '/' ? "" : "/");
    for (p = (const unsigned char *)full; *p && n + 4 < size; p++) {
        unsigned char c = *p == '\\' ? '/' : *p;
        if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || strchr("/-_.~:", c)) {
            out[n++] = (char)c;
        } else {
            n += (size_t)snprintf(out + n, size - n, "%%%02X", c);
        }
    }
    out[n] = 0;
}

static void print_real(double x) {
    printf(" %a", x);
}

static void read_values(int inst, int first, const char *kind) {
    static fmi2ValueReference vrs[MAX_VALUES];
    static fmi2Real reals[MAX_VALUES];
    static fmi2Integer ints[MAX_VALUES];
    static fmi2String strings[MAX_VALUES];
    size_t n = 0, k;
    fmi2Status s;
    for (int i = first; i < ntokens; i++)
        vrs[n++] = (fmi2ValueReference)strtoul(tokens[i], NULL, 0);
    if (!strcmp(kind, "real")) {
        s = fmi.GetReal(instances[inst], vrs, n, reals);
        printf("get_real %d", s);
        if (s <= 1)
            for (k = 0; k < n; k++)
                print_real(reals[k]);
    } else if (!strcmp(kind, "integer") || !strcmp(kind, "boolean")) {
        s = (kind[0] == 'i' ? fmi.GetInteger : fmi.GetBoolean)(instances[inst], vrs, n, ints);
        printf("get_%s %d", kind, s);
        if (s <= 1)
            for (k = 0; k < n; k++)
                printf(" %d", ints[k]);
    } else {
        s = fmi.GetString(instances[inst], vrs, n, strings);
        printf("get_string %d", s);
        if (s <= 1)
            for (k = 0; k < n; k++)
                printf(" [%s]", strings[k] ? strings[k] : "(null)");
    }
    printf("\n");
}

static void write_values(int inst, int first, const char *kind) {
    static fmi2ValueReference vrs[MAX_VALUES];
    static fmi2Real reals[MAX_VALUES];
    static fmi2Integer ints[MAX_VALUES];
    static fmi2String strings[MAX_VALUES];
    size_t n = 0;
    fmi2Status s;
    for (int i = first; i + 1 < ntokens; i += 2) {
        vrs[n] = (fmi2ValueReference)strtoul(tokens[i], NULL, 0);
        if (!strcmp(kind, "real"))
            reals[n] = real_arg(i + 1);
        else if (!strcmp(kind, "string"))
            strings[n] = string_arg(i + 1);
        else
            ints[n] = (fmi2Integer)integer_arg(i + 1);
        n++;
    }
    if (!strcmp(kind, "real"))
        s = fmi.SetReal(instances[inst], vrs, n, reals);
    else if (!strcmp(kind, "string"))
        s = fmi.SetString(instances[inst], vrs, n, strings);
    else
        s = (kind[0] == 'i' ? fmi.SetInteger : fmi.SetBoolean)(instances[inst], vrs, n, ints);
    printf("set_%s %d\n", kind, s);
}

static void run(int inst) {
    static fmi2ValueReference vrs[MAX_VALUES];
    static fmi2Real values[MAX_VALUES];
    double h = real_arg(2);
    long from = integer_arg(3), to = integer_arg(4), k;
    size_t n = 0, j;
    fmi2Status s = 0;
    for (int i = 5; i < ntokens; i++)
        vrs[n++] = (fmi2ValueReference)strtoul(tokens[i], NULL, 0);
    for (k = from; k <= to; k++) {
        if (k > from) {
            s = fmi.DoStep(instances[inst], (double)(k - 1) * h, h, 1);
            if (s != 0) {
                printf("run %ld %d\n", k, s);
                return;
            }
        }
        s = fmi.GetReal(instances[inst], vrs, n, values);
        printf("point %ld %d", k, s);
        if (s != 0) {
            printf("\n");
            return;
        }
        for (j = 0; j < n; j++)
            print_real(values[j]);
        printf("\n");
    }
    printf("run %ld %d\n", to, s);
}

static void serialize(int inst, int st, const char *path) {
    size_t size = 0;
    char *bytes;
    FILE *f;
    fmi2Status s = fmi.SerializedFMUstateSize(instances[inst], states[st], &size);
    if (s != 0) {
        printf("serialize %d\n", s);
        return;
    }
    bytes = (char *)malloc(size ? size : 1);
    s = fmi.SerializeFMUstate(instances[inst], states[st], bytes, size);
    if (s == 0) {
        f = fopen(path, "wb");
        if (!f || fwrite(bytes, 1, size, f) != size || fclose(f))
            fail("cannot write the state file");
    }
    free(bytes);
    printf("serialize %d %lu\n", s, (unsigned long)size);
}

static void deserialize(int inst, const char *path, int st) {
    FILE *f = fopen(path, "rb");
    long size;
    char *bytes;
    fmi2Status s;
    if (!f)
        fail("cannot open the state file");
    fseek(f, 0, SEEK_END);
    size = ftell(f);
    fseek(f, 0, SEEK_SET);
    bytes = (char *)malloc(size ? (size_t)size : 1);
    if (fread(bytes, 1, (size_t)size, f) != (size_t)size)
        fail("cannot read the state file");
    fclose(f);
    s = fmi.DeSerializeFMUstate(instances[inst], bytes, (size_t)size, &states[st]);
    free(bytes);
    printf("deserialize %d\n", s);
}

static uintptr_t hex_arg(int i) {
    return (uintptr_t)strtoull(arg(i), NULL, 16);
}

static void command(void) {
    const char *c = arg(0);
    if (!strcmp(c, "version")) {
        printf("version %s\n", fmi.GetVersion());
    } else if (!strcmp(c, "platform")) {
        printf("platform %s\n", fmi.GetTypesPlatform());
    } else if (!strcmp(c, "echo")) {
        printf("echo");
        for (int i = 1; i < ntokens; i++)
            printf(" %s", tokens[i]);
        printf("\n");
    } else if (!strcmp(c, "instantiate")) {
        int i = slot(1);
        const char *uri = string_arg(4);
        const char *cb = arg(5);
        char uri_buffer[8192];
        if (uri && uri[0] == '@') {
            file_uri(uri + 1, uri_buffer, sizeof uri_buffer);
            uri = uri_buffer;
            fprintf(stderr, "fmi_host: resource URI %s\n", uri);
        }
        instances[i] = fmi.Instantiate(string_arg(2), 1, string_arg(3), uri,
                                       !strcmp(cb, "logger") ? &with_logger
                                       : !strcmp(cb, "silent") ? &silent
                                                               : NULL,
                                       0, (fmi2Boolean)integer_arg(6));
        printf("instantiate %s\n", instances[i] ? "handle" : "NULL");
    } else if (!strcmp(c, "garbage")) {
        instances[slot(1)] = (fmi2Component)hex_arg(2);
    } else if (!strcmp(c, "garbage_state")) {
        states[slot(1)] = (fmi2FMUstate)hex_arg(2);
    } else if (!strcmp(c, "free")) {
        fmi.FreeInstance(instances[slot(1)]);
        printf("free\n");
    } else if (!strcmp(c, "setup")) {
        printf("setup %d\n", fmi.SetupExperiment(instances[slot(1)], (fmi2Boolean)integer_arg(2), real_arg(3),
                                                 real_arg(4), (fmi2Boolean)integer_arg(5), real_arg(6)));
    } else if (!strcmp(c, "debug")) {
        fmi2String categories[64];
        long n = integer_arg(3);
        for (int i = 4; i < ntokens && i - 4 < 64; i++)
            categories[i - 4] = string_arg(i);
        printf("debug %d\n", fmi.SetDebugLogging(instances[slot(1)], (fmi2Boolean)integer_arg(2), (size_t)n,
                                                 n > 0 && ntokens > 4 ? categories : NULL));
    } else if (!strcmp(c, "enter")) {
        printf("enter %d\n", fmi.EnterInitializationMode(instances[slot(1)]));
    } else if (!strcmp(c, "exit")) {
        printf("exit %d\n", fmi.ExitInitializationMode(instances[slot(1)]));
    } else if (!strcmp(c, "terminate")) {
        printf("terminate %d\n", fmi.Terminate(instances[slot(1)]));
    } else if (!strcmp(c, "reset")) {
        printf("reset %d\n", fmi.Reset(instances[slot(1)]));
    } else if (!strcmp(c, "cancel")) {
        printf("cancel %d\n", fmi.CancelStep(instances[slot(1)]));
    } else if (!strncmp(c, "get_", 4) && strcmp(c, "get_state") && strcmp(c, "get_real_null")) {
        read_values(slot(1), 2, c + 4);
    } else if (!strncmp(c, "set_", 4) && strcmp(c, "set_state")) {
        write_values(slot(1), 2, c + 4);
    } else if (!strcmp(c, "get_real_null")) {
        printf("get_real_null %d\n", fmi.GetReal(instances[slot(1)], NULL, (size_t)integer_arg(2), NULL));
    } else if (!strcmp(c, "dostep")) {
        printf("dostep %d\n", fmi.DoStep(instances[slot(1)], real_arg(2), real_arg(3), (fmi2Boolean)integer_arg(4)));
    } else if (!strcmp(c, "run")) {
        run(slot(1));
    } else if (!strcmp(c, "get_state")) {
        printf("get_state %d\n", fmi.GetFMUstate(instances[slot(1)], &states[slot(2)]));
    } else if (!strcmp(c, "set_state")) {
        printf("set_state %d\n", fmi.SetFMUstate(instances[slot(1)], states[slot(2)]));
    } else if (!strcmp(c, "free_state")) {
        printf("free_state %d\n", fmi.FreeFMUstate(instances[slot(1)], &states[slot(2)]));
    } else if (!strcmp(c, "serialize")) {
        serialize(slot(1), slot(2), arg(3));
    } else if (!strcmp(c, "deserialize")) {
        deserialize(slot(1), arg(2), slot(3));
    } else if (!strcmp(c, "status")) {
        int i = slot(1), kind = (int)integer_arg(2);
        fmi2Status value = -1;
        fmi2Real real = NAN;
        fmi2Boolean boolean = -1;
        fmi2Status s1 = fmi.GetStatus(instances[i], kind, &value);
        fmi2Status s2 = fmi.GetRealStatus(instances[i], kind, &real);
        fmi2Status s3 = fmi.GetBooleanStatus(instances[i], kind, &boolean);
        printf("status %d %d %d", s1, s2, s3);
        print_real(s2 == 0 ? real : 0.0);
        printf(" %d\n", s3 == 0 ? boolean : -1);
    } else {
        fail("unknown command");
    }
}

int main(int argc, char **argv) {
    static char line[1 << 16];
    FILE *script;
    if (argc != 3) {
        fprintf(stderr, "usage: fmi_host LIBRARY SCRIPT\n");
        return 2;
    }
    load(argv[1]);
    script = strcmp(argv[2], "-") ? fopen(argv[2], "r") : stdin;
    if (!script) {
        fprintf(stderr, "fmi_host: cannot open %s\n", argv[2]);
        return 2;
    }
    while (fgets(line, sizeof line, script)) {
        line_number++;
        split(line);
        if (ntokens)
            command();
        fflush(stdout);
    }
    return 0;
}
