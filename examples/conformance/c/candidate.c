/*
 * An independent implementation of W and W^-1 in C that follows mfcbeam's
 * file contract, written for `mfcbeam conform`. Build with the system cc:
 *
 *     cc -O2 -o candidate candidate.c -lm
 *     candidate simulate   --model M.json --input IN.csv --output OUT.csv
 *     candidate compensate --model M.json --input IN.csv --output OUT.csv --limits=LO,HI
 *
 * `simulate` reads column `u` and appends `y = W[u]`; `compensate` reads
 * column `y_d` and appends `u = W^-1[y_d]` and `saturated`. The model file's
 * `state` is honoured: x_init of (8) for the plays, chi at the first sample
 * for creep; its `offset` is added to the output (subtracted from a target).
 * An optional `superposition` S (thresholds with one 0, weights) acts on
 * H + C: y = S[H + C] + offset, and W^-1 applies S^-1 (its inverse rules)
 * to the target first. A dead time `delay` of d samples delays the output,
 * y_k = S[H + C]_{max(k-d,0)} + offset, with `delay_state` the d values
 * still to come out (absent: the first sample's value fills the line);
 * `compensate` previews the target by d samples, u_k = W^-1[y_d]_{k+d}
 * (the last d samples hold the last target). Numbers are written with
 * %.17g, which reads back bit-identically.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void die(const char *what, const char *detail) {
    fprintf(stderr, "candidate: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

/* ---- a minimal JSON reader: objects, arrays, numbers, literals ---- */
typedef struct Json {
    int kind; /* 0 null/bool, 1 number, 2 array, 3 object, 4 string */
    double num;
    size_t n;
    struct Json *items;
    char **keys;
} Json;

static const char *ws(const char *p) {
    while (*p == ' ' || *p == '\n' || *p == '\r' || *p == '\t') p++;
    return p;
}

static const char *parse(const char *p, Json *out);

static const char *parse_string(const char *p, char **s) {
    const char *start = ++p;
    while (*p && *p != '"') p += (*p == '\\') ? 2 : 1;
    if (!*p) die("malformed JSON", "unterminated string");
    *s = malloc((size_t)(p - start) + 1);
    memcpy(*s, start, (size_t)(p - start));
    (*s)[p - start] = 0;
    return p + 1;
}

static const char *parse(const char *p, Json *out) {
    memset(out, 0, sizeof *out);
    p = ws(p);
    if (*p == '{' || *p == '[') {
        int obj = *p == '{';
        out->kind = obj ? 3 : 2;
        p = ws(p + 1);
        while (*p != (obj ? '}' : ']')) {
            out->items = realloc(out->items, (out->n + 1) * sizeof(Json));
            if (obj) {
                out->keys = realloc(out->keys, (out->n + 1) * sizeof(char *));
                if (*p != '"') die("malformed JSON", "expected a key");
                p = ws(parse_string(p, &out->keys[out->n]));
                if (*p != ':') die("malformed JSON", "expected ':'");
                p++;
            }
            p = ws(parse(p, &out->items[out->n]));
            out->n++;
            if (*p == ',') p = ws(p + 1);
            else if (*p != (obj ? '}' : ']')) die("malformed JSON", "expected ',' or a closing bracket");
        }
        return p + 1;
    }
    if (*p == '"') {
        char *s;
        out->kind = 4;
        p = parse_string(p, &s);
        free(s);
        return p;
    }
    if (!strncmp(p, "null", 4) || !strncmp(p, "true", 4)) return p + 4;
    if (!strncmp(p, "false", 5)) return p + 5;
    char *end;
    out->kind = 1;
    out->num = strtod(p, &end);
    if (end == p) die("malformed JSON", "expected a value");
    return end;
}

static const Json *get(const Json *obj, const char *key) {
    for (size_t i = 0; obj && obj->kind == 3 && i < obj->n; i++)
        if (!strcmp(obj->keys[i], key)) return &obj->items[i];
    return NULL;
}

static double *numbers(const Json *arr, size_t *n) {
    if (!arr || arr->kind != 2) die("model file", "expected an array of numbers");
    double *v = malloc((arr->n + 1) * sizeof(double));
    for (size_t i = 0; i < arr->n; i++) v[i] = arr->items[i].num;
    *n = arr->n;
    return v;
}

/* ---- the operators ---- */
typedef struct {
    size_t n;          /* plays */
    double *r, *w, *x; /* thresholds, weights, states */
} Pi;

typedef struct {
    size_t n, m;              /* thresholds, eigenvalues */
    double *r, *w, *g, *chi; /* chi[i * m + j] */
} Creep;

static double play(double v, double r, double x) { return fmax(v - r, fmin(v + r, x)); }

static double pi_step(Pi *h, double v) {
    double y = 0.0;
    for (size_t i = 0; i < h->n; i++) {
        h->x[i] = play(v, h->r[i], h->x[i]);
        y += h->w[i] * h->x[i];
    }
    return y;
}

/* The inverse states of (22): x'_j = s_j x_j + sum_{i>j} w_i x_i. */
static void inverse_state(const Pi *h, double *xi) {
    double tail = 0.0;
    double *s = malloc(h->n * sizeof(double));
    double acc = 0.0;
    for (size_t j = 0; j < h->n; j++) s[j] = acc += h->w[j];
    for (size_t j = h->n; j-- > 0;) {
        xi[j] = s[j] * h->x[j] + tail;
        tail += h->w[j] * h->x[j];
    }
    free(s);
}

/* The transformation rules (22). */
static Pi pi_inverse(const Pi *h) {
    Pi inv = {h->n, malloc(h->n * sizeof(double)), malloc(h->n * sizeof(double)),
              malloc(h->n * sizeof(double))};
    double s_prev = h->w[0];
    inv.r[0] = 0.0;
    inv.w[0] = 1.0 / h->w[0];
    for (size_t j = 1; j < h->n; j++) {
        double s = s_prev + h->w[j];
        inv.r[j] = inv.r[j - 1] + s_prev * (h->r[j] - h->r[j - 1]);
        inv.w[j] = -h->w[j] / (s * s_prev);
        s_prev = s;
    }
    inverse_state(h, inv.x);
    return inv;
}

static double creep_output(const Creep *c) {
    double y = 0.0;
    for (size_t i = 0; i < c->n; i++) {
        double mean = 0.0;
        for (size_t j = 0; j < c->m; j++) mean += c->chi[i * c->m + j];
        y += c->w[i] * mean / (double)c->m;
    }
    return y;
}

static void creep_advance(Creep *c, double v) {
    for (size_t i = 0; i < c->n; i++)
        for (size_t j = 0; j < c->m; j++) {
            double *chi = &c->chi[i * c->m + j];
            *chi += c->g[j] * play(v - *chi, c->r[i], 0.0);
        }
}

/* The superposition operator: S[z] = sum_i w_i d_i(z), one-sided dead
 * zones d_i(z) = max(z - r_i, 0) above r = 0, min(z - r_i, 0) below. */
typedef struct {
    size_t n, zero;
    double *r, *w;
} Sup;

static double sup_eval(const Sup *s, double z) {
    double y = 0.0;
    for (size_t i = 0; i < s->n; i++) {
        double d = z - s->r[i];
        if (s->r[i] > 0.0) d = fmax(d, 0.0);
        if (s->r[i] < 0.0) d = fmin(d, 0.0);
        y += s->w[i] * d;
    }
    return y;
}

/* S^-1: thresholds S(r_i), weights 1/w_0 and -w_i / (slope_out slope_in),
 * each side outward from the zero threshold. */
static Sup sup_inverse(const Sup *s) {
    Sup inv = {s->n, s->zero, malloc(s->n * sizeof(double)), malloc(s->n * sizeof(double))};
    inv.r[s->zero] = 0.0;
    inv.w[s->zero] = 1.0 / s->w[s->zero];
    for (int side = -1; side <= 1; side += 2) {
        double slope = s->w[s->zero], value = 0.0;
        size_t inner = s->zero;
        for (long j = (long)s->zero + side; j >= 0 && j < (long)s->n; j += side) {
            value += slope * (s->r[j] - s->r[inner]);
            double outer = slope + s->w[j];
            inv.r[j] = value;
            inv.w[j] = -s->w[j] / (outer * slope);
            slope = outer;
            inner = (size_t)j;
        }
    }
    return inv;
}

static char *slurp(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) die("cannot open", path);
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)len + 1);
    if (fread(buf, 1, (size_t)len, f) != (size_t)len) die("cannot read", path);
    buf[len] = 0;
    fclose(f);
    return buf;
}

/* The next line of a buffer (terminated in place, '\r' removed), or NULL. */
static char *next_line(char **cursor) {
    char *p = *cursor;
    if (!p || !*p) return NULL;
    char *nl = strchr(p, '\n');
    *cursor = nl ? nl + 1 : NULL;
    if (nl) *nl = 0;
    size_t len = strlen(p);
    if (len && p[len - 1] == '\r') p[len - 1] = 0;
    return p;
}

int main(int argc, char **argv) {
    if (argc < 2 || (strcmp(argv[1], "simulate") && strcmp(argv[1], "compensate")))
        die("usage: candidate simulate|compensate --model M --input IN --output OUT [--limits=LO,HI]", NULL);
    int simulate = !strcmp(argv[1], "simulate");
    const char *model = NULL, *input = NULL, *output = NULL;
    double lo = -INFINITY, hi = INFINITY;
    for (int k = 2; k < argc; k++) {
        if (!strncmp(argv[k], "--limits=", 9)) {
            if (sscanf(argv[k] + 9, "%lf,%lf", &lo, &hi) != 2) die("bad --limits", argv[k]);
        } else if (k + 1 < argc && !strcmp(argv[k], "--model")) model = argv[++k];
        else if (k + 1 < argc && !strcmp(argv[k], "--input")) input = argv[++k];
        else if (k + 1 < argc && !strcmp(argv[k], "--output")) output = argv[++k];
        else if (k + 1 < argc && !strcmp(argv[k], "--limits")) {
            if (sscanf(argv[++k], "%lf,%lf", &lo, &hi) != 2) die("bad --limits", argv[k]);
        } else die("unexpected argument", argv[k]);
    }
    if (!model || !input || !output) die("--model, --input and --output are required", NULL);

    Json root;
    char *text = slurp(model);
    parse(text, &root);
    const Json *ts = get(&root, "sample_time"), *hj = get(&root, "hysteresis"), *cj = get(&root, "creep");
    const Json *off = get(&root, "offset");
    double offset = off && off->kind == 1 ? off->num : 0.0;
    if (!ts || !hj) die("model file", "needs sample_time and hysteresis");
    Pi h;
    size_t nw;
    h.r = numbers(get(hj, "thresholds"), &h.n);
    h.w = numbers(get(hj, "weights"), &nw);
    h.x = get(hj, "state") ? numbers(get(hj, "state"), &nw) : calloc(h.n, sizeof(double));
    Creep c = {0};
    if (cj && cj->kind == 3) {
        size_t n2;
        double *a = numbers(get(cj, "eigenvalues"), &c.m);
        c.r = numbers(get(cj, "thresholds"), &c.n);
        c.w = numbers(get(cj, "weights"), &n2);
        c.g = malloc(c.m * sizeof(double));
        for (size_t j = 0; j < c.m; j++) c.g[j] = -expm1(-a[j] * ts->num);
        c.chi = calloc(c.n * c.m, sizeof(double));
        const Json *st = get(cj, "state");
        for (size_t i = 0; st && st->kind == 2 && i < st->n && i < c.n; i++)
            for (size_t j = 0; j < st->items[i].n && j < c.m; j++)
                c.chi[i * c.m + j] = st->items[i].items[j].num;
    }

    Sup sup = {0}, sup_inv = {0};
    const Json *sj = get(&root, "superposition");
    if (sj && sj->kind == 3) {
        size_t n2;
        sup.r = numbers(get(sj, "thresholds"), &sup.n);
        sup.w = numbers(get(sj, "weights"), &n2);
        while (sup.zero < sup.n && sup.r[sup.zero] != 0.0) sup.zero++;
        if (sup.zero == sup.n || n2 != sup.n) die("model file", "bad superposition");
        sup_inv = sup_inverse(&sup);
    }

    const Json *dj = get(&root, "delay"), *dsj = get(&root, "delay_state");
    size_t d = dj && dj->kind == 1 ? (size_t)dj->num : 0, nd = 0, head = 0;
    double *line_values = NULL; /* the dead time's ring: d values of S[H + C] */
    if (d) {
        line_values = dsj && dsj->kind == 2 ? numbers(dsj, &nd) : calloc(d, sizeof(double));
        if (dsj && dsj->kind == 2 && nd != d) die("model file", "delay_state needs delay values");
    }
    int started = dsj && dsj->kind == 2;

    /* the trace: header, then rows passed through with the new columns */
    char *csv = slurp(input);
    FILE *out = fopen(output, "w");
    if (!out) die("cannot write", output);
    /* split into lines in place, dropping any '\r' */
    char *next = csv;
    char *line = next_line(&next);
    if (!line) die("empty trace", input);
    const char *want = simulate ? "u" : "y_d";
    int col = -1, idx = 0;
    for (const char *p = line, *q; p; p = q ? q + 1 : NULL, idx++) {
        q = strchr(p, ',');
        size_t len = q ? (size_t)(q - p) : strlen(p);
        if (len == strlen(want) && !strncmp(p, want, len)) col = idx;
    }
    if (col < 0) die("missing column", want);
    fprintf(out, "%s%s\n", line, simulate ? ",y" : ",u,saturated");
    Pi inv = simulate ? h : pi_inverse(&h);
    /* every row first: compensate looks d samples ahead */
    size_t rows = 0, cap = 0;
    char **lines = NULL;
    double *values = NULL;
    while ((line = next_line(&next))) {
        if (!*line) continue;
        const char *p = line;
        for (int k = 0; k < col && p; k++) p = strchr(p, ',') ? strchr(p, ',') + 1 : NULL;
        if (!p) die("short row in", input);
        if (rows == cap) {
            cap = cap ? 2 * cap : 256;
            lines = realloc(lines, cap * sizeof(char *));
            values = realloc(values, cap * sizeof(double));
            if (!lines || !values) die("out of memory", NULL);
        }
        lines[rows] = line;
        values[rows++] = strtod(p, NULL);
    }
    for (size_t k = 0; k < rows; k++) {
        line = lines[k];
        double v = values[k];
        if (simulate) {
            double z = pi_step(&h, v);
            if (c.n) {
                z += creep_output(&c);
                creep_advance(&c, v);
            }
            z = sup.n ? sup_eval(&sup, z) : z;
            if (d) {
                if (!started) {
                    for (size_t j = 0; j < d; j++) line_values[j] = z;
                    started = 1;
                }
                double oldest = line_values[head];
                line_values[head] = z;
                head = (head + 1) % d;
                z = oldest;
            }
            fprintf(out, "%s,%.17g\n", line, z + offset);
        } else {
            v = values[k + d < rows ? k + d : rows - 1];
            double cr = c.n ? creep_output(&c) : 0.0;
            double target = sup.n ? sup_eval(&sup_inv, v - offset) : v - offset;
            double want_v = pi_step(&inv, target - cr);
            double u = fmin(fmax(want_v, lo), hi);
            int saturated = u != want_v;
            pi_step(&h, u);
            if (saturated) inverse_state(&h, inv.x);
            if (c.n) creep_advance(&c, u);
            fprintf(out, "%s,%.17g,%d\n", line, u, saturated);
        }
    }
    if (fclose(out)) die("cannot write", output);
    return 0;
}
