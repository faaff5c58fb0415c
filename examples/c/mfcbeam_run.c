/*
 * mfcbeam's model and compensator from C, through libmfcbeam.a, following
 * the file contract (docs/FILES.md) so that `mfcbeam conform` can check it:
 *
 *     cc -O2 -I include -o mfcbeam_run examples/c/mfcbeam_run.c \
 *        target/release/libmfcbeam.a -lpthread -ldl -lm
 *     mfcbeam_run simulate   --model M.json --input IN.csv --output OUT.csv [--f32]
 *     mfcbeam_run compensate --model M.json --input IN.csv --output OUT.csv --limits=LO,HI [--f32]
 *
 * `simulate` appends y = W[u] to the input's columns, `compensate` appends
 * u = W^-1[y_d] and `saturated` (the whole column in one call,
 * mfcbeam_compensator_compensate_into). Without --f32 it uses the heap handles
 * (mfcbeam_model_from_json, mfcbeam_compensator_from_json, f64); with --f32
 * the caller-owned storage (MfcbeamModelStorageF32, MfcbeamCompensatorStorageF32) that a
 * target without a heap would use. A model with a dead time of d samples
 * is compensated with the target d samples ahead (mfcbeam_compensator_delay:
 * the compensator inverts the memory part; a file's target is known ahead).
 * Errors: one line on stderr, exit 2, no output file.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mfcbeam.h"

static void die(const char *what, const char *detail) {
    fprintf(stderr, "mfcbeam_run: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

static char *read_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) die("cannot open", path);
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    size_t got;
    while ((got = fread(buf + n, 1, cap - n - 1, f)) > 0) {
        n += got;
        if (n + 1 == cap) buf = realloc(buf, cap *= 2);
    }
    fclose(f);
    buf[n] = 0;
    return buf;
}

/* A trace: the header line, the data lines, and one column parsed. */
typedef struct {
    char *header;
    char **lines;
    size_t rows;
    double *values;
} Trace;

static Trace read_trace(const char *path, const char *column) {
    Trace t = {0};
    char *text = read_file(path);
    char *save = NULL;
    char *line = strtok_r(text, "\r\n", &save);
    if (!line) die("no header row", path);
    t.header = line;
    /* the column's index in the header */
    int index = -1, i = 0;
    for (const char *p = line; p; i++) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len == strlen(column) && strncmp(p, column, len) == 0) index = i;
        p = end ? end + 1 : NULL;
    }
    if (index < 0) die("missing column", column);
    size_t cap = 1024;
    t.lines = malloc(cap * sizeof(char *));
    t.values = malloc(cap * sizeof(double));
    while ((line = strtok_r(NULL, "\r\n", &save))) {
        if (t.rows == cap) {
            cap *= 2;
            t.lines = realloc(t.lines, cap * sizeof(char *));
            t.values = realloc(t.values, cap * sizeof(double));
        }
        const char *p = line;
        for (int k = 0; k < index && p; k++) {
            p = strchr(p, ',');
            if (p) p++;
        }
        char *end;
        double v = p ? strtod(p, &end) : 0.0;
        if (!p || end == p || (*end && *end != ',')) die("not a number in column", column);
        t.lines[t.rows] = line;
        t.values[t.rows++] = v;
    }
    if (t.rows == 0) die("no data rows", path);
    return t;
}

int main(int argc, char **argv) {
    const char *command = argc > 1 ? argv[1] : "";
    const char *model = NULL, *input = NULL, *output = NULL;
    double lower = -1000.0, upper = 1000.0;
    int single = 0;
    for (int i = 2; i < argc; i++) {
        if (!strcmp(argv[i], "--model") && i + 1 < argc) model = argv[++i];
        else if (!strcmp(argv[i], "--input") && i + 1 < argc) input = argv[++i];
        else if (!strcmp(argv[i], "--output") && i + 1 < argc) output = argv[++i];
        else if (!strncmp(argv[i], "--limits=", 9)) {
            if (sscanf(argv[i] + 9, "%lf,%lf", &lower, &upper) != 2) die("bad --limits", argv[i]);
        } else if (!strcmp(argv[i], "--f32")) single = 1;
        else die("unknown argument", argv[i]);
    }
    int simulate = !strcmp(command, "simulate");
    if (!simulate && strcmp(command, "compensate")) die("usage", "mfcbeam_run simulate|compensate --model M --input I --output O");
    if (!model || !input || !output) die("missing", "--model, --input and --output are required");

    char *json = read_file(model);
    Trace t = read_trace(input, simulate ? "u" : "y_d");
    double *out = malloc(t.rows * sizeof(double));
    int *sat = calloc(t.rows, sizeof(int));
    char err[512];

    if (simulate && !single) {
        MfcbeamModelHandle *w = mfcbeam_model_from_json(json, err, sizeof err);
        if (!w) die(model, err);
        for (size_t k = 0; k < t.rows; k++) out[k] = mfcbeam_model_step(w, t.values[k]);
        mfcbeam_model_free(w);
    } else if (simulate) {
        static MfcbeamModelStorageF32 w;
        if (mfcbeam_model_f32_init_json(&w, json, err, sizeof err) != 0) die(model, err);
        for (size_t k = 0; k < t.rows; k++) out[k] = mfcbeam_model_f32_step(&w, (float)t.values[k]);
    } else if (!single) {
        MfcbeamCompensatorHandle *c = mfcbeam_compensator_from_json(json, lower, upper, err, sizeof err);
        if (!c) die(model, err);
        size_t d = mfcbeam_compensator_delay(c);
        /* the column previewed by d samples, then the whole signal in one call */
        for (size_t k = 0; k < t.rows; k++) out[k] = t.values[k + d < t.rows ? k + d : t.rows - 1];
        if (mfcbeam_compensator_compensate_into(c, out, out, sat, t.rows) != 0) die(model, "the compensator refused the run");
        for (size_t k = 0; k < t.rows; k++) sat[k] &= MFCBEAM_FLAG_SATURATED;
        mfcbeam_compensator_free(c);
    } else {
        static MfcbeamCompensatorStorageF32 c;
        if (mfcbeam_compensator_f32_init_json(&c, json, lower, upper, err, sizeof err) != 0) die(model, err);
        size_t d = mfcbeam_compensator_f32_delay(&c);
        float *v = malloc(t.rows * sizeof(float) + 1); /* + 1: malloc(0) may be NULL */
        if (!v) die("out of memory", input);
        for (size_t k = 0; k < t.rows; k++) v[k] = (float)t.values[k + d < t.rows ? k + d : t.rows - 1];
        if (mfcbeam_compensator_f32_compensate_into(&c, v, v, sat, t.rows) != 0) die(model, "the compensator refused the run");
        for (size_t k = 0; k < t.rows; k++) {
            out[k] = v[k];
            sat[k] &= MFCBEAM_FLAG_SATURATED;
        }
        free(v);
    }

    /* write next to the output, then rename: never a partial output file */
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.tmp", output);
    FILE *f = fopen(tmp, "wb");
    if (!f) die("cannot write", tmp);
    fprintf(f, "%s,%s\n", t.header, simulate ? "y" : "u,saturated");
    for (size_t k = 0; k < t.rows; k++) {
        if (simulate) fprintf(f, "%s,%.17g\n", t.lines[k], out[k]);
        else fprintf(f, "%s,%.17g,%d\n", t.lines[k], out[k], sat[k] ? 1 : 0);
    }
    if (fclose(f) != 0 || rename(tmp, output) != 0) {
        remove(tmp);
        die("cannot write", output);
    }
    return 0;
}
