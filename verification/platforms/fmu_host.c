/*
 * fmu_host: a minimal FMI 2.0 / 3.0 Co-Simulation host in C, written
 * against the standard's headers only (none of mfcbeam's code), built for
 * each platform: dlopen on Linux, LoadLibrary on Windows (run under wine
 * there), and run on 64-bit ARM under qemu-user.
 *
 *     fmu_host DIR INPUTS OUTPUTS SAVE_AT ROWS.txt
 *
 * DIR is an unpacked FMU. INPUTS are the value references of its Float64
 * inputs ("1" or "1,12"); OUTPUTS those of its outputs, each with its
 * type, r for Float64 and b for Boolean ("2r,3b,4b"). ROWS.txt holds one
 * line per sample, each input as the 16 hexadecimal digits of its IEEE 754
 * bits, so that no decimal conversion of a C library comes in between.
 *
 * For every row the host sets the inputs, takes one doStep of the FMU's
 * sample time (its calculated parameter 7), and prints the outputs, Float64
 * as their 16 hexadecimal digits, Boolean as 0 or 1. Before row SAVE_AT it
 * saves the FMU state; after the last row it restores it, replays the rows
 * from SAVE_AT and prints them again after a line "restored" (they must
 * equal the first pass's). Any call that fails: one line on stderr, exit 2.
 */
#define __USE_MINGW_ANSI_STDIO 1
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"

#ifdef _WIN32
#include <windows.h>
#define EXTENSION ".dll"
#define FOLDER2 "win64"
#define FOLDER3 "x86_64-windows"
#define SEPARATOR "\\"
#else
#include <dlfcn.h>
#define EXTENSION ".so"
#define SEPARATOR "/"
#if defined(__aarch64__)
#define FOLDER2 "aarch64-linux"
#define FOLDER3 "aarch64-linux"
#else
#define FOLDER2 "linux64"
#define FOLDER3 "x86_64-linux"
#endif
#endif

#define MAX_VARIABLES 64
#define SAMPLE_TIME_VR 7

static void die(const char *what, const char *detail) {
    fprintf(stderr, "fmu_host: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

static char *read_text(const char *path, size_t *length) {
    FILE *f = fopen(path, "rb");
    if (!f) die("cannot open", path);
    size_t cap = 1 << 16, n = 0, got;
    char *buf = malloc(cap);
    if (!buf) die("out of memory", NULL);
    while ((got = fread(buf + n, 1, cap - n - 1, f)) > 0) {
        n += got;
        if (n + 1 == cap) {
            cap *= 2;
            buf = realloc(buf, cap);
            if (!buf) die("out of memory", NULL);
        }
    }
    fclose(f);
    buf[n] = 0;
    if (length) *length = n;
    return buf;
}

/* The value of attribute `name` in the description: the first one. */
static char *attribute(const char *xml, const char *name) {
    char key[64];
    snprintf(key, sizeof key, " %s=\"", name);
    const char *p = strstr(xml, key);
    if (!p) return NULL;
    p += strlen(key);
    const char *end = strchr(p, '"');
    if (!end) return NULL;
    char *v = malloc((size_t)(end - p) + 1);
    memcpy(v, p, (size_t)(end - p));
    v[end - p] = 0;
    return v;
}

static void *library;

static void *symbol(const char *name) {
#ifdef _WIN32
    void *f = (void *)GetProcAddress((HMODULE)library, name);
#else
    void *f = dlsym(library, name);
#endif
    if (!f) die("missing symbol", name);
    return f;
}

static void load(const char *path) {
#ifdef _WIN32
    library = (void *)LoadLibraryA(path);
    if (!library) {
        char why[4200];
        snprintf(why, sizeof why, "%s (error %lu)", path, (unsigned long)GetLastError());
        die("LoadLibrary failed", why);
    }
#else
    library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) die("dlopen failed", dlerror());
#endif
}

static double from_bits(uint64_t b) {
    double x;
    memcpy(&x, &b, sizeof x);
    return x;
}

static uint64_t to_bits(double x) {
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* A comma-separated list of value references, with a type letter each if
 * `types` is given. */
static size_t parse_list(const char *text, unsigned *vrs, char *types) {
    size_t n = 0;
    const char *p = text;
    while (*p) {
        if (n == MAX_VARIABLES) die("too many variables", text);
        char *end;
        unsigned long v = strtoul(p, &end, 10);
        if (end == p) die("not a value reference list", text);
        vrs[n] = (unsigned)v;
        p = end;
        if (types) {
            if (*p != 'r' && *p != 'b') die("each output needs its type, r or b", text);
            types[n] = *p++;
        }
        n++;
        if (*p == ',') p++;
        else if (*p) die("not a value reference list", text);
    }
    return n;
}

/* The rows of inputs, `count` numbers each. */
static double *parse_rows(char *text, size_t count, size_t *rows) {
    size_t cap = 1024, n = 0;
    double *v = malloc(cap * sizeof *v);
    char *p = text;
    for (;;) {
        while (*p == ' ' || *p == '\n' || *p == '\r') p++;
        if (!*p) break;
        char *end;
        unsigned long long b = strtoull(p, &end, 16);
        if (end - p != 16) die("an input is not 16 hexadecimal digits", NULL);
        if (n == cap) {
            cap *= 2;
            v = realloc(v, cap * sizeof *v);
            if (!v) die("out of memory", NULL);
        }
        v[n++] = from_bits((uint64_t)b);
        p = end;
    }
    if (count == 0 || n % count) die("the rows do not hold whole samples", NULL);
    *rows = n / count;
    return v;
}

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                    fmi2String category, fmi2String message, ...) {
    (void)env;
    (void)name;
    (void)category;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "fmu (status %d): ", (int)status);
    vfprintf(stderr, message, args);
    fprintf(stderr, "\n");
    va_end(args);
}

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                    fmi3String message) {
    (void)env;
    (void)category;
    fprintf(stderr, "fmu (status %d): %s\n", (int)status, message);
}

/* One FMU of either version behind the same few calls. */
typedef struct {
    int version;
    void *instance;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2GetBooleanTYPE *get_boolean;
    fmi2DoStepTYPE *do_step2;
    fmi2GetFMUstateTYPE *get_state2;
    fmi2SetFMUstateTYPE *set_state2;
    fmi2FreeFMUstateTYPE *free_state2;
    fmi3SetFloat64TYPE *set_float64;
    fmi3GetFloat64TYPE *get_float64;
    fmi3GetBooleanTYPE *get_boolean3;
    fmi3DoStepTYPE *do_step3;
    fmi3GetFMUStateTYPE *get_state3;
    fmi3SetFMUStateTYPE *set_state3;
    fmi3FreeFMUStateTYPE *free_state3;
} Fmu;

static void check(int status, const char *call) {
    /* OK (0) and Warning (1) in both versions */
    if (status > 1) die("the FMU refused", call);
}

static void set_inputs(Fmu *f, const unsigned *vrs, size_t n, const double *values) {
    if (f->version == 2)
        check(f->set_real(f->instance, vrs, n, values), "SetReal");
    else
        check(f->set_float64(f->instance, vrs, n, values, n), "SetFloat64");
}

static double get_real(Fmu *f, unsigned vr) {
    double v;
    if (f->version == 2)
        check(f->get_real(f->instance, &vr, 1, &v), "GetReal");
    else
        check(f->get_float64(f->instance, &vr, 1, &v, 1), "GetFloat64");
    return v;
}

static int get_boolean(Fmu *f, unsigned vr) {
    if (f->version == 2) {
        fmi2Boolean b;
        check(f->get_boolean(f->instance, &vr, 1, &b), "GetBoolean");
        return b != fmi2False;
    }
    fmi3Boolean b;
    check(f->get_boolean3(f->instance, &vr, 1, &b, 1), "GetBoolean");
    return b ? 1 : 0;
}

static void do_step(Fmu *f, double t, double h) {
    if (f->version == 2) {
        check(f->do_step2(f->instance, t, h, fmi2True), "DoStep");
        return;
    }
    fmi3Boolean event, terminate, early;
    fmi3Float64 last;
    check(f->do_step3(f->instance, t, h, fmi3True, &event, &terminate, &early, &last), "DoStep");
}

/* The outputs of one row, as one line. */
static void outputs(Fmu *f, const unsigned *vrs, const char *types, size_t n, FILE *out) {
    for (size_t i = 0; i < n; i++) {
        if (i) fputc(' ', out);
        if (types[i] == 'r')
            fprintf(out, "%016" PRIx64, to_bits(get_real(f, vrs[i])));
        else
            fprintf(out, "%d", get_boolean(f, vrs[i]));
    }
    fputc('\n', out);
}

/* Step rows [from, rows) and print their outputs; the state is saved
 * before row `save_at`. */
static void run(Fmu *f, const double *inputs, size_t rows, size_t from, const unsigned *in,
                size_t n_in, const unsigned *out, const char *types, size_t n_out, double h,
                size_t save_at, void **state, FILE *sink) {
    for (size_t k = from; k < rows; k++) {
        if (k == save_at && state) {
            if (f->version == 2)
                check(f->get_state2(f->instance, state), "GetFMUstate");
            else
                check(f->get_state3(f->instance, state), "GetFMUState");
        }
        set_inputs(f, in, n_in, inputs + k * n_in);
        do_step(f, (double)k * h, h);
        outputs(f, out, types, n_out, sink);
    }
}

int main(int argc, char **argv) {
    if (argc != 6) die("usage", "fmu_host DIR INPUTS OUTPUTS SAVE_AT ROWS.txt");
    const char *dir = argv[1];
    unsigned in[MAX_VARIABLES], out[MAX_VARIABLES];
    char types[MAX_VARIABLES];
    size_t n_in = parse_list(argv[2], in, NULL);
    size_t n_out = parse_list(argv[3], out, types);
    size_t save_at = (size_t)strtoul(argv[4], NULL, 10);
    size_t rows;
    double *inputs = parse_rows(read_text(argv[5], NULL), n_in, &rows);
    if (save_at >= rows) die("SAVE_AT must be a row", argv[4]);

    char path[4096];
    snprintf(path, sizeof path, "%s%smodelDescription.xml", dir, SEPARATOR);
    char *xml = read_text(path, NULL);
    char *version = attribute(xml, "fmiVersion");
    char *id = attribute(xml, "modelIdentifier");
    if (!version || !id) die("no fmiVersion or modelIdentifier in", path);
    Fmu f;
    memset(&f, 0, sizeof f);
    f.version = version[0] == '2' ? 2 : version[0] == '3' ? 3 : 0;
    if (!f.version) die("not FMI 2.0 or 3.0", version);
    snprintf(path, sizeof path, "%s%sbinaries%s%s%s%s%s", dir, SEPARATOR, SEPARATOR,
             f.version == 2 ? FOLDER2 : FOLDER3, SEPARATOR, id, EXTENSION);
    load(path);

    char resources[4096];
    if (f.version == 2) {
        /* a file URI: forward slashes, and a drive letter after file:/// */
        snprintf(resources, sizeof resources, "file://%s%s/resources", dir[0] == '/' ? "" : "/",
                 dir);
        for (char *p = resources; *p; p++)
            if (*p == '\\') *p = '/';
        char *guid = attribute(xml, "guid");
        if (!guid) die("no guid in the description", NULL);
        fmi2CallbackFunctions callbacks = {logger2, calloc, free, NULL, NULL};
        fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)symbol("fmi2Instantiate");
        f.set_real = (fmi2SetRealTYPE *)symbol("fmi2SetReal");
        f.get_real = (fmi2GetRealTYPE *)symbol("fmi2GetReal");
        f.get_boolean = (fmi2GetBooleanTYPE *)symbol("fmi2GetBoolean");
        f.do_step2 = (fmi2DoStepTYPE *)symbol("fmi2DoStep");
        f.get_state2 = (fmi2GetFMUstateTYPE *)symbol("fmi2GetFMUstate");
        f.set_state2 = (fmi2SetFMUstateTYPE *)symbol("fmi2SetFMUstate");
        f.free_state2 = (fmi2FreeFMUstateTYPE *)symbol("fmi2FreeFMUstate");
        f.instance = instantiate("host", fmi2CoSimulation, guid, resources, &callbacks, fmi2False,
                                 fmi2False);
        if (!f.instance) die("fmi2Instantiate returned NULL", resources);
        check(((fmi2SetupExperimentTYPE *)symbol("fmi2SetupExperiment"))(f.instance, fmi2False,
                                                                          0.0, 0.0, fmi2False, 0.0),
              "SetupExperiment");
        check(((fmi2EnterInitializationModeTYPE *)symbol("fmi2EnterInitializationMode"))(f.instance),
              "EnterInitializationMode");
        check(((fmi2ExitInitializationModeTYPE *)symbol("fmi2ExitInitializationMode"))(f.instance),
              "ExitInitializationMode");
    } else {
        snprintf(resources, sizeof resources, "%s%sresources%s", dir, SEPARATOR, SEPARATOR);
        char *token = attribute(xml, "instantiationToken");
        if (!token) die("no instantiationToken in the description", NULL);
        fmi3InstantiateCoSimulationTYPE *instantiate =
            (fmi3InstantiateCoSimulationTYPE *)symbol("fmi3InstantiateCoSimulation");
        f.set_float64 = (fmi3SetFloat64TYPE *)symbol("fmi3SetFloat64");
        f.get_float64 = (fmi3GetFloat64TYPE *)symbol("fmi3GetFloat64");
        f.get_boolean3 = (fmi3GetBooleanTYPE *)symbol("fmi3GetBoolean");
        f.do_step3 = (fmi3DoStepTYPE *)symbol("fmi3DoStep");
        f.get_state3 = (fmi3GetFMUStateTYPE *)symbol("fmi3GetFMUState");
        f.set_state3 = (fmi3SetFMUStateTYPE *)symbol("fmi3SetFMUState");
        f.free_state3 = (fmi3FreeFMUStateTYPE *)symbol("fmi3FreeFMUState");
        f.instance = instantiate("host", token, resources, fmi3False, fmi3False, fmi3False,
                                 fmi3False, NULL, 0, NULL, logger3, NULL);
        if (!f.instance) die("fmi3InstantiateCoSimulation returned NULL", resources);
        check(((fmi3EnterInitializationModeTYPE *)symbol("fmi3EnterInitializationMode"))(
                  f.instance, fmi3False, 0.0, 0.0, fmi3False, 0.0),
              "EnterInitializationMode");
        check(((fmi3ExitInitializationModeTYPE *)symbol("fmi3ExitInitializationMode"))(f.instance),
              "ExitInitializationMode");
    }
    double h = get_real(&f, SAMPLE_TIME_VR);
    if (!(h > 0.0)) die("the sample time is not positive", NULL);

    /* the first pass, then the rows from SAVE_AT again from the saved state */
    void *state = NULL;
    run(&f, inputs, rows, 0, in, n_in, out, types, n_out, h, save_at, &state, stdout);
    if (f.version == 2)
        check(f.set_state2(f.instance, state), "SetFMUstate");
    else
        check(f.set_state3(f.instance, state), "SetFMUState");
    printf("restored\n");
    run(&f, inputs, rows, save_at, in, n_in, out, types, n_out, h, rows, NULL, stdout);
    if (f.version == 2) {
        f.free_state2(f.instance, &state);
        ((fmi2TerminateTYPE *)symbol("fmi2Terminate"))(f.instance);
        ((fmi2FreeInstanceTYPE *)symbol("fmi2FreeInstance"))(f.instance);
    } else {
        f.free_state3(f.instance, &state);
        ((fmi3TerminateTYPE *)symbol("fmi3Terminate"))(f.instance);
        ((fmi3FreeInstanceTYPE *)symbol("fmi3FreeInstance"))(f.instance);
    }
    return 0;
}
