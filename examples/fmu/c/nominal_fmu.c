/*
 * An FMU written independently of mfcbeam's code, in C (FMI 2.0
 * Co-Simulation), with the paper's nominal model compiled in: what a
 * compensator generated from a block diagram or written for firmware looks
 * like. It reads no model file, so `mfcbeam conform --fmu` checks it in the
 * fixed mode against golden/nominal_model.json.
 *
 * Its compensator does not use the inverse rules: at each sample it solves
 * H(v) + C = target for v by bisection on the forward plays (H is
 * increasing in v from any state), then clips. Its variables are named in
 * its own way (target, voltage, clipped, bad_input, v_min, v_max for the
 * compensator; voltage, effective_voltage for the model), so checking it
 * also checks `--fmu-variable`.
 *
 * Build (build.sh does this and zips the FMU):
 *   cc -shared -fPIC -O2 -DKIND_COMPENSATOR [-DFAULT_...] -o nominal.so nominal_fmu.c -lm
 * KIND_COMPENSATOR or KIND_MODEL; convention errors on purpose:
 *   FAULT_CREEP_CURRENT   creep driven by the current input (the model) or,
 *                         in the compensator, by the output being computed,
 *                         instead of the previous one
 *   FAULT_HALF_THRESHOLDS every play threshold halved (a band width taken
 *                         for the threshold)
 *   FAULT_NO_SATURATION   the limits ignored
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- FMI 2.0 types, as the standard declares them ---- */
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
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef struct {
    const fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    const fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))

/* ---- the nominal model ---- */
#define TS 2e-4
#define NH 12
#define NC 12
#define NE 5
static const double W_H[NH] = {0.45, 0.0963, 0.0773, 0.062, 0.0498, 0.0399,
                               0.0321, 0.0257, 0.0206, 0.0166, 0.0133, -0.01};
static const double W_C[NC] = {0.08, 0.006, 0.005, 0.004, 0.003, 0.002,
                               0.002, 0.001, 0.001, 0.001, 0.001, 0.001};
static const double EIG[NE] = {500.0, 50.0, 5.0, 0.5, 0.05};

static double threshold(int i) {
    double r = i * 1000.0 / 12.0;
#ifdef FAULT_HALF_THRESHOLDS
    r *= 0.5;
#endif
    return r;
}

typedef struct {
    double play[NH];         /* hysteresis play states */
    double chi[NC][NE];      /* elementary creep states */
    double input, output, last_v, v_min, v_max, time;
    int saturated, fault, stepping;
} State;

typedef struct {
    State s;
    fmi2CallbackFunctions cb;
    char name[64];
} Instance;

static double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* H of v from the current plays, without changing them */
static double hysteresis_at(const State *s, double v) {
    double h = 0.0;
    for (int i = 0; i < NH; i++) h += W_H[i] * clamp(s->play[i], v - threshold(i), v + threshold(i));
    return h;
}

static void advance_plays(State *s, double v) {
    for (int i = 0; i < NH; i++) s->play[i] = clamp(s->play[i], v - threshold(i), v + threshold(i));
}

/* the creep output of states chi */
static double creep_of(double chi[NC][NE]) {
    double c = 0.0;
    for (int i = 0; i < NC; i++) {
        double mean = 0.0;
        for (int j = 0; j < NE; j++) mean += chi[i][j];
        c += W_C[i] * mean / NE;
    }
    return c;
}

/* one exact zero-order-hold step of every elementary creep operator */
static void advance_creep(double chi[NC][NE], double v) {
    for (int i = 0; i < NC; i++) {
        double r = i * 1000.0 / 12.0;
        for (int j = 0; j < NE; j++) {
            double z = v - chi[i][j];
            double dead = z > r ? z - r : (z < -r ? z + r : 0.0);
            chi[i][j] += -expm1(-EIG[j] * TS) * dead;
        }
    }
}

/* what the model outputs for input v at this sample (no state change) */
static double model_at(const State *s, double v) {
#ifdef FAULT_CREEP_CURRENT
    double chi[NC][NE];
    memcpy(chi, s->chi, sizeof chi);
    advance_creep(chi, v);
    return hysteresis_at(s, v) + creep_of(chi);
#else
    return hysteresis_at(s, v) + creep_of((double (*)[NE])s->chi);
#endif
}

#ifndef KIND_COMPENSATOR
static void model_step(State *s) {
    double v = isfinite(s->input) ? s->input : s->last_v;
    s->fault = !isfinite(s->input);
    s->output = model_at(s, v);
    advance_plays(s, v);
    advance_creep(s->chi, v);
    s->last_v = v;
}
#else
static void compensator_step(State *s) {
    double v;
    s->fault = !isfinite(s->input);
    s->saturated = 0;
    if (s->fault) {
        v = s->last_v;
    } else {
        /* bracket, then bisect to adjacent doubles */
        double lo = -1.0, hi = 1.0;
        while (model_at(s, lo) > s->input && lo > -1e300) lo *= 2.0;
        while (model_at(s, hi) < s->input && hi < 1e300) hi *= 2.0;
        for (int k = 0; k < 2200; k++) {
            double mid = 0.5 * (lo + hi);
            if (mid <= lo || mid >= hi) break;
            if (model_at(s, mid) < s->input) lo = mid; else hi = mid;
        }
        v = fabs(model_at(s, lo) - s->input) <= fabs(model_at(s, hi) - s->input) ? lo : hi;
#ifndef FAULT_NO_SATURATION
        if (v < s->v_min) { v = s->v_min; s->saturated = 1; }
        if (v > s->v_max) { v = s->v_max; s->saturated = 1; }
#endif
    }
    s->output = v;
    advance_plays(s, v);
    advance_creep(s->chi, v);
    s->last_v = v;
}
#endif

/* ---- value references ---- */
#ifdef KIND_COMPENSATOR
enum { VR_IN = 0, VR_OUT = 1, VR_SAT = 2, VR_FAULT = 3, VR_MIN = 4, VR_MAX = 5 };
#else
enum { VR_IN = 0, VR_OUT = 1, VR_FAULT = 3 };
#endif

static void logmsg(Instance *in, fmi2Status st, const char *msg) {
    if (in && in->cb.logger) in->cb.logger(in->cb.componentEnvironment, in->name, st, "log", "%s", msg);
}

static void reset_state(State *s) {
    memset(s, 0, sizeof *s);
    s->v_min = -1000.0;
    s->v_max = 1000.0;
}

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }
EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi2OK;
}

EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                                     const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    (void)res; (void)visible; (void)logging;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0) return NULL;
    Instance *in = calloc(1, sizeof *in);
    if (!in) return NULL;
    if (cb) memcpy(&in->cb, cb, sizeof in->cb);
    strncpy(in->name, name ? name : "nominal", sizeof in->name - 1);
    reset_state(&in->s);
    return in;
}

EXPORT void fmi2FreeInstance(fmi2Component c) { free(c); }
EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1) {
    (void)td; (void)tol; (void)sd; (void)t1;
    ((Instance *)c)->s.time = t0;
    return fmi2OK;
}
EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) { ((Instance *)c)->s.stepping = 1; return fmi2OK; }
EXPORT fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }
EXPORT fmi2Status fmi2Reset(fmi2Component c) { reset_state(&((Instance *)c)->s); return fmi2OK; }

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    State *s = &((Instance *)c)->s;
    for (size_t k = 0; k < n; k++) {
        switch (vr[k]) {
        case VR_IN: v[k] = s->input; break;
        case VR_OUT: v[k] = s->output; break;
#ifdef KIND_COMPENSATOR
        case VR_MIN: v[k] = s->v_min; break;
        case VR_MAX: v[k] = s->v_max; break;
#endif
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    State *s = &((Instance *)c)->s;
    for (size_t k = 0; k < n; k++) {
        switch (vr[k]) {
        case VR_IN: s->input = v[k]; break;
#ifdef KIND_COMPENSATOR
        case VR_MIN: if (s->stepping) return fmi2Error; s->v_min = v[k]; break;
        case VR_MAX: if (s->stepping) return fmi2Error; s->v_max = v[k]; break;
#endif
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    State *s = &((Instance *)c)->s;
    for (size_t k = 0; k < n; k++) {
        switch (vr[k]) {
#ifdef KIND_COMPENSATOR
        case VR_SAT: v[k] = s->saturated; break;
#endif
        case VR_FAULT: v[k] = s->fault; break;
        default: return fmi2Error;
        }
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    (void)c; (void)vr; (void)v;
    return n ? fmi2Error : fmi2OK;
}
EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    (void)c; (void)vr; (void)v;
    return n ? fmi2Error : fmi2OK;
}
EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    (void)c; (void)vr; (void)v;
    return n ? fmi2Error : fmi2OK;
}
EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)c; (void)vr; (void)v;
    return n ? fmi2Error : fmi2OK;
}
EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    (void)c; (void)vr; (void)v;
    return n ? fmi2Error : fmi2OK;
}

EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *st) {
    if (!*st) *st = malloc(sizeof(State));
    if (!*st) return fmi2Error;
    memcpy(*st, &((Instance *)c)->s, sizeof(State));
    return fmi2OK;
}
EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate st) {
    memcpy(&((Instance *)c)->s, st, sizeof(State));
    return fmi2OK;
}
EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *st) {
    (void)c;
    free(*st);
    *st = NULL;
    return fmi2OK;
}

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior) {
    Instance *in = c;
    (void)no_prior;
    long n = lround(h / TS);
    if (n < 1 || fabs(n * TS - h) > 1e-9 * h) {
        logmsg(in, fmi2Error, "the step is not a whole number of samples");
        return fmi2Error;
    }
    for (long k = 0; k < n; k++) {
#ifdef KIND_COMPENSATOR
        compensator_step(&in->s);
#else
        model_step(&in->s);
#endif
    }
    in->s.time = t + h;
    return fmi2OK;
}

#define UNSUPPORTED { return fmi2Error; }
EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { (void)c; (void)s; (void)n; UNSUPPORTED }
EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { (void)c; (void)s; (void)b; (void)n; UNSUPPORTED }
EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) { (void)c; (void)s; (void)b; (void)n; UNSUPPORTED }
EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; UNSUPPORTED }
EXPORT fmi2Status fmi2GetStatus(fmi2Component c, int k, fmi2Status *v) { (void)c; (void)k; (void)v; UNSUPPORTED }
EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, int k, fmi2Real *v) { (void)c; (void)k; (void)v; UNSUPPORTED }
EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, int k, fmi2Integer *v) { (void)c; (void)k; (void)v; UNSUPPORTED }
EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, int k, fmi2Boolean *v) { (void)c; (void)k; (void)v; UNSUPPORTED }
EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, int k, fmi2String *v) { (void)c; (void)k; (void)v; UNSUPPORTED }
