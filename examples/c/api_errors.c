/*
 * The C API refuses bad input cleanly: malformed JSON, inadmissible
 * parameters, bad limits, NULL and uninitialised handles, capacity, a
 * state estimate's bad record. Each
 * check prints one line; the exit code is the number of failed checks.
 *
 *     cc -I include -o api_errors examples/c/api_errors.c \
 *        target/debug/libmfcbeam.a -lpthread -ldl -lm && ./api_errors
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mfcbeam.h"

static int failed = 0;

static void check(int ok, const char *what, const char *detail) {
    printf("%s: %s%s%s\n", ok ? "ok" : "FAILED", what, detail ? " -- " : "", detail ? detail : "");
    failed += !ok;
}

static const char *GOOD =
    "{\"sample_time\": 0.0002, \"hysteresis\": {\"thresholds\": [0, 100], \"weights\": [0.5, 0.25]}}";

int main(void) {
    char err[256];

    /* JSON constructors: NULL and the reason */
    err[0] = 0;
    MfcbeamModelHandle *m = mfcbeam_model_from_json("{\"sample_time\": 0.0002, \"hysteresis\": [", err, sizeof err);
    check(!m && strstr(err, "malformed"), "malformed JSON", err);
    err[0] = 0;
    m = mfcbeam_model_from_json(
        "{\"sample_time\": 0.0002, \"hysteresis\": {\"thresholds\": [0, 2, 1], \"weights\": [1, 1, 1]}}", err,
        sizeof err);
    check(!m && strstr(err, "hysteresis.thresholds"), "thresholds not increasing", err);
    err[0] = 0;
    m = mfcbeam_model_from_json(
        "{\"sample_time\": 0.0002, \"hysteresis\": {\"thresholds\": [0, 1], \"weights\": [1, -2]}}", err, sizeof err);
    check(!m && strstr(err, "(11)"), "partial sum not positive", err);
    err[0] = 0;
    m = mfcbeam_model_from_json("{\"sample_time\": -1, \"hysteresis\": {\"thresholds\": [0], \"weights\": [1]}}",
                                err, sizeof err);
    check(!m && strstr(err, "sample_time"), "negative sample time", err);
    err[0] = 0;
    m = mfcbeam_model_from_json(NULL, err, sizeof err);
    check(!m && strstr(err, "NULL"), "NULL JSON", err);
    err[0] = 0;
    MfcbeamCompensatorHandle *c = mfcbeam_compensator_from_json(GOOD, 10.0, -10.0, err, sizeof err);
    check(!c && strstr(err, "limits"), "lower limit above upper", err);
    c = mfcbeam_compensator_from_json(GOOD, NAN, 10.0, err, sizeof err);
    check(!c, "NaN limit", err);
    m = mfcbeam_model_from_json("not json", NULL, 0);
    check(!m, "no error buffer", NULL);
    char tiny[8];
    m = mfcbeam_model_from_json("not json", tiny, sizeof tiny);
    check(!m && strlen(tiny) == 7, "error truncated to the buffer", tiny);

    /* counts that would decide an allocation: refused before it, not an abort */
    static const char *HUGE_DELAYS[] = {"1000000000000", "18446744073709551615", "100000000", "100001"};
    for (size_t i = 0; i < sizeof HUGE_DELAYS / sizeof *HUGE_DELAYS; i++) {
        char json[256];
        snprintf(json, sizeof json,
                 "{\"sample_time\": 0.0002, \"hysteresis\": {\"thresholds\": [0, 100], \"weights\": [0.5, 0.25]}, "
                 "\"delay\": %s}",
                 HUGE_DELAYS[i]);
        err[0] = 0;
        m = mfcbeam_model_from_json(json, err, sizeof err);
        check(!m && strstr(err, "delay") && strstr(err, "exceeds the limit"), "huge dead time (model)", err);
        err[0] = 0;
        c = mfcbeam_compensator_from_json(json, -1000.0, 1000.0, err, sizeof err);
        check(!c && strstr(err, "delay") && strstr(err, "exceeds the limit"), "huge dead time (compensator)", err);
    }
    err[0] = 0;
    m = mfcbeam_model_from_json("{\"sample_time\": 0.0002, \"hysteresis\": {\"thresholds\": [0], \"weights\": [1]}, "
                                "\"creep\": {\"thresholds\": [0], \"weights\": [0], \"eigenvalues\": "
                                "[1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17,18,19,20,21,22,23,24,25,26,27,28,29,30,31,32,"
                                "33,34,35,36,37,38,39,40,41,42,43,44,45,46,47,48,49,50,51,52,53,54,55,56,57,58,59,60,61,62,"
                                "63,64,65]}}",
                                err, sizeof err);
    check(!m && strstr(err, "creep.eigenvalues") && strstr(err, "exceeds the limit"), "65 creep eigenvalues", err);

    /* NULL handles are refused, not dereferenced */
    int flags = 0;
    check(isnan(mfcbeam_model_step(NULL, 1.0)), "model step on NULL", NULL);
    double u = mfcbeam_compensator_compensate(NULL, 1.0, &flags);
    check(isnan(u) && flags == MFCBEAM_FLAG_INVALID_HANDLE, "compensate on NULL", NULL);
    double run_targets[3] = {1.0, 2.0, 3.0}, run_u[3] = {0.0, 0.0, 0.0};
    int run_flags[3] = {0, 0, 0};
    int refused = mfcbeam_compensator_compensate_into(NULL, run_targets, run_u, run_flags, 3);
    check(refused == -1 && isnan(run_u[2]) && run_flags[2] == MFCBEAM_FLAG_INVALID_HANDLE, "a run on NULL", NULL);
    mfcbeam_model_reset(NULL);
    mfcbeam_model_free(NULL);
    mfcbeam_compensator_reset(NULL);
    mfcbeam_compensator_free(NULL);
    check(1, "reset and free of NULL", NULL);

    /* caller-owned storage */
    static MfcbeamCompensatorStorageF32 zeroed;
    float v = mfcbeam_compensator_f32_compensate(&zeroed, 1.0f, &flags);
    check(isnan(v) && flags == MFCBEAM_FLAG_INVALID_HANDLE, "uninitialised storage", NULL);
    v = mfcbeam_compensator_f32_compensate(NULL, 1.0f, &flags);
    check(isnan(v) && flags == MFCBEAM_FLAG_INVALID_HANDLE, "NULL storage", NULL);
    float run_v[2] = {1.0f, 2.0f};
    refused = mfcbeam_compensator_f32_compensate_into(&zeroed, run_v, run_v, run_flags, 2);
    check(refused == -1 && isnan(run_v[1]) && run_flags[1] == MFCBEAM_FLAG_INVALID_HANDLE, "a run on uninitialised storage", NULL);

    const double r[2] = {0.0, 100.0}, w[2] = {0.5, 0.25};
    const double rc[1] = {0.0}, wc[1] = {0.05}, a[2] = {50.0, 0.5};
    MfcbeamParameters p = {0.0002, r, w, 2, rc, wc, 1, a, 2, 0.0, NULL, NULL, 0, 0, 0.0, 0.0, 0.0, 0.0};
    static MfcbeamCompensatorStorageF32 comp;
    static MfcbeamModelStorageF32 plant;
    err[0] = 0;
    check(mfcbeam_compensator_f32_init(&comp, &p, -500.0, 500.0, err, sizeof err) == 0, "init from arrays", err);
    err[0] = 0;
    check(mfcbeam_model_f32_init(&plant, &p, err, sizeof err) == 0, "model init from arrays", err);
    double worst = 0.0;
    for (int k = 0; k < 2000; k++) {
        float y = (float)(60.0 * sin(k * 0.01));
        float out = mfcbeam_model_f32_step(&plant, mfcbeam_compensator_f32_compensate(&comp, y, &flags));
        if (fabs(out - y) > worst) worst = fabs(out - y);
    }
    char line[64];
    snprintf(line, sizeof line, "max |W[W^-1[y]] - y| = %.3g V", worst);
    check(worst < 1e-3 && flags == 0, "f32 identity", line);
    mfcbeam_compensator_f32_compensate(&comp, NAN, &flags);
    check(flags == MFCBEAM_FLAG_NON_FINITE_TARGET, "NaN target flagged", NULL);
    mfcbeam_compensator_f32_compensate(&comp, 1e6f, &flags);
    check(flags == MFCBEAM_FLAG_SATURATED, "unreachable target saturates", NULL);

    /* an asymmetric superposition operator S after H + C: slopes 1.3, 1, 0.6 */
    const double rs[3] = {-40.0, 0.0, 30.0}, ws[3] = {0.3, 1.0, -0.4};
    MfcbeamParameters asym = p;
    asym.superposition_thresholds = rs;
    asym.superposition_weights = ws;
    asym.superposition_len = 3;
    err[0] = 0;
    check(mfcbeam_compensator_f32_init(&comp, &asym, -500.0, 500.0, err, sizeof err) == 0, "init with S", err);
    err[0] = 0;
    check(mfcbeam_model_f32_init(&plant, &asym, err, sizeof err) == 0, "model init with S", err);
    worst = 0.0;
    for (int k = 0; k < 2000; k++) {
        float y = (float)(60.0 * sin(k * 0.01));
        float out = mfcbeam_model_f32_step(&plant, mfcbeam_compensator_f32_compensate(&comp, y, &flags));
        if (fabs(out - y) > worst) worst = fabs(out - y);
    }
    snprintf(line, sizeof line, "max |W[W^-1[y]] - y| = %.3g V", worst);
    check(worst < 1e-3 && flags == 0, "f32 identity through S", line);
    const double ws_bad[3] = {0.3, 1.0, -1.0};
    asym.superposition_weights = ws_bad;
    err[0] = 0;
    check(mfcbeam_compensator_f32_init(&comp, &asym, -500.0, 500.0, err, sizeof err) == -1 &&
              strstr(err, "superposition"),
          "a decreasing S", err);
    mfcbeam_compensator_f32_init(&comp, &p, -500.0, 500.0, err, sizeof err);

    /* a dead time of 3 samples: the compensator inverts the memory part, so
       the caller gives it the target 3 samples ahead */
    MfcbeamParameters delayed = p;
    delayed.delay = 3;
    static MfcbeamCompensatorStorageF64 comp_d;
    static MfcbeamModelStorageF64 plant_d;
    err[0] = 0;
    check(mfcbeam_compensator_f64_init(&comp_d, &delayed, -500.0, 500.0, err, sizeof err) == 0 &&
              mfcbeam_compensator_f64_delay(&comp_d) == 3,
          "init with a dead time", err);
    err[0] = 0;
    check(mfcbeam_model_f64_init(&plant_d, &delayed, err, sizeof err) == 0, "model init with a dead time", err);
    worst = 0.0;
    for (int k = 0; k < 2000; k++) {
        double ahead = 60.0 * sin((k + 3) * 0.01), y = 60.0 * sin(k * 0.01);
        double out = mfcbeam_model_f64_step(&plant_d, mfcbeam_compensator_f64_compensate(&comp_d, ahead, &flags));
        if (k >= 3 && fabs(out - y) > worst) worst = fabs(out - y);
    }
    snprintf(line, sizeof line, "max |W[W^-1[y]] - y| from sample 3 = %.3g V", worst);
    check(worst < 1e-9, "f64 identity through a dead time", line);
    delayed.delay = MFCBEAM_MAX_DELAY + 1;
    err[0] = 0;
    check(mfcbeam_model_f64_init(&plant_d, &delayed, err, sizeof err) == -1 && strstr(err, "delay"),
          "a dead time beyond the capacity", err);
    check(mfcbeam_compensator_f64_delay(NULL) == 0, "the delay of NULL storage", NULL);

    /* linear dynamics: a resonance adds one sample to the preview; a damping
       of 1 is refused by name */
    MfcbeamParameters resonant = p;
    resonant.resonance_frequency = 740.0;
    resonant.resonance_damping = 0.014;
    resonant.delay_fraction = 0.25;
    err[0] = 0;
    check(mfcbeam_compensator_f64_init(&comp_d, &resonant, -500.0, 500.0, err, sizeof err) == 0 &&
              mfcbeam_compensator_f64_delay(&comp_d) == 1,
          "a resonance's lag in the preview", err);
    err[0] = 0;
    check(mfcbeam_model_f64_init(&plant_d, &resonant, err, sizeof err) == 0, "model init with dynamics", err);
    worst = 0.0;
    for (int k = 0; k < 2000; k++) {
        double ahead = 60.0 * sin((k + 1) * 0.01), y = 60.0 * sin(k * 0.01);
        double out = mfcbeam_model_f64_step(&plant_d, mfcbeam_compensator_f64_compensate(&comp_d, ahead, &flags));
        if (k >= 1 && fabs(out - y) > worst) worst = fabs(out - y);
    }
    snprintf(line, sizeof line, "max |W[W^-1[y]] - y| through G from sample 1 = %.3g V", worst);
    check(worst < 1e-9, "f64 identity through a resonance and a delay fraction", line);
    resonant.resonance_damping = 1.0;
    err[0] = 0;
    check(mfcbeam_compensator_f64_init(&comp_d, &resonant, -500.0, 500.0, err, sizeof err) == -1 &&
              strstr(err, "dynamics.resonance.damping"),
          "a damping out of range", err);

    MfcbeamParameters bad = p;
    bad.hysteresis_weights = NULL;
    err[0] = 0;
    check(mfcbeam_compensator_f32_init(&comp, &bad, -500.0, 500.0, err, sizeof err) == -1 && strstr(err, "NULL"),
          "NULL array", err);
    v = mfcbeam_compensator_f32_compensate(&comp, 1.0f, &flags);
    check(isnan(v) && flags == MFCBEAM_FLAG_INVALID_HANDLE, "failed init leaves the storage refused", NULL);
    err[0] = 0;
    check(mfcbeam_compensator_f32_init(&comp, NULL, -500.0, 500.0, err, sizeof err) == -1, "NULL parameters", err);
    err[0] = 0;
    check(mfcbeam_compensator_f32_init(NULL, &p, -500.0, 500.0, err, sizeof err) == -1, "NULL storage", err);
    double many[MFCBEAM_MAX_PLAYS + 1], ones[MFCBEAM_MAX_PLAYS + 1];
    for (int i = 0; i <= MFCBEAM_MAX_PLAYS; i++) many[i] = i, ones[i] = 1.0;
    MfcbeamParameters big = {0.0002, many, ones, MFCBEAM_MAX_PLAYS + 1, NULL, NULL, 0, NULL, 0, 0.0, NULL, NULL, 0, 0,
                             0.0, 0.0, 0.0, 0.0};
    static MfcbeamCompensatorStorageF64 comp64;
    err[0] = 0;
    check(mfcbeam_compensator_f64_init(&comp64, &big, -1.0, 1.0, err, sizeof err) == -1 && strstr(err, "capacity"),
          "beyond the capacity", err);
    MfcbeamParameters unordered = p;
    const double r_bad[2] = {0.0, -1.0};
    unordered.hysteresis_thresholds = r_bad;
    err[0] = 0;
    check(mfcbeam_compensator_f64_init(&comp64, &unordered, -1.0, 1.0, err, sizeof err) == -1 &&
              strstr(err, "increase"),
          "inadmissible arrays", err);
    err[0] = 0;
    check(mfcbeam_compensator_f64_init_json(&comp64, "{", -1.0, 1.0, err, sizeof err) == -1, "storage from bad JSON",
          err);

    /* the state estimate: NULL and the reason */
    double su[4] = {0.0, 50.0, 150.0, 60.0}, sy[4] = {0.0, 25.0, 80.0, 40.0};
    err[0] = 0;
    char *state = mfcbeam_estimate_state(NULL, su, sy, 4, 0, 0, err, sizeof err);
    check(!state && strstr(err, "NULL"), "estimate from NULL JSON", err);
    err[0] = 0;
    state = mfcbeam_estimate_state(GOOD, su, NULL, 4, 0, 0, err, sizeof err);
    check(!state && strstr(err, "y: NULL"), "estimate on a NULL output", err);
    err[0] = 0;
    state = mfcbeam_estimate_state(GOOD, su, sy, 4, 9, 0, err, sizeof err);
    check(!state && strstr(err, "until"), "estimation window beyond the record", err);
    su[2] = NAN;
    err[0] = 0;
    state = mfcbeam_estimate_state(GOOD, su, sy, 4, 0, 0, err, sizeof err);
    check(!state && strstr(err, "finite"), "estimate on a NaN input", err);
    su[2] = 150.0;
    state = mfcbeam_estimate_state(GOOD, su, sy, 4, 0, 1, err, sizeof err);
    check(state && strstr(state, "\"state\""), "estimate on a good record", state ? NULL : err);
    mfcbeam_string_free(state);
    mfcbeam_string_free(NULL);

    printf("%d failed\n", failed);
    return failed;
}
