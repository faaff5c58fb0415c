/*
 * A compensator's start-up from an unknown memory: the actuator has been
 * driven before (here: up to 450 V and back to 0), so its plays and creep
 * hold a past the program does not know. A short excitation over the
 * working range is recorded, mfcbeam_estimate_state estimates the memory
 * from it, and the compensator built from the estimate (the state after
 * the window) takes over. Against the compensator started virgin, the
 * tracking error after the start-up; and the model in the estimated state
 * driven by the compensator gives back the target to rounding
 * (W[W^-1[y]] = y). Exit code 0 when both hold.
 *
 *     cc -I include -o start_up examples/c/start_up.c \
 *        target/release/libmfcbeam.a -lpthread -ldl -lm && ./start_up
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "mfcbeam.h"

/* the actuator's model (identified before; its memory is what is unknown) */
static const char *MODEL =
    "{\"sample_time\": 0.0002,"
    " \"hysteresis\": {\"thresholds\": [0, 100, 200, 300, 400, 500],"
    "                  \"weights\": [0.45, 0.1, 0.08, 0.06, 0.05, 0.04]},"
    " \"creep\": {\"thresholds\": [0, 250], \"weights\": [0.06, 0.02], \"eigenvalues\": [50, 5]}}";

#define WINDOW 2500 /* 0.5 s: a hold, then one cycle over the working range */
#define RUN 5000    /* 1 s of tracking after it */
#define PI 3.14159265358979323846

int main(void) {
    char err[256];
    MfcbeamModelHandle *actuator = mfcbeam_model_from_json(MODEL, err, sizeof err);
    if (!actuator) {
        printf("FAILED: %s\n", err);
        return 1;
    }
    /* the past: up to 450 V and back to 0 */
    for (int k = 0; k <= 2000; k++) mfcbeam_model_step(actuator, 450.0 * (1.0 - fabs(k - 1000.0) / 1000.0));

    /* the start-up excitation: 0.1 s held at 0 V, then a sine of 300 V */
    static double u[WINDOW], y[WINDOW];
    for (int k = 0; k < WINDOW; k++) {
        double t = (k - 500) * 0.0002;
        u[k] = k < 500 ? 0.0 : 300.0 * sin(2.0 * PI * 2.5 * t);
        y[k] = mfcbeam_model_step(actuator, u[k]);
    }
    char *estimated = mfcbeam_estimate_state(MODEL, u, y, WINDOW, 0, 1, err, sizeof err);
    if (!estimated) {
        printf("FAILED: %s\n", err);
        return 1;
    }
    MfcbeamCompensatorHandle *comp = mfcbeam_compensator_from_json(estimated, -1000.0, 1000.0, err, sizeof err);
    MfcbeamCompensatorHandle *virgin = mfcbeam_compensator_from_json(MODEL, -1000.0, 1000.0, err, sizeof err);
    MfcbeamModelHandle *model = mfcbeam_model_from_json(estimated, err, sizeof err);
    if (!comp || !virgin || !model) {
        printf("FAILED: %s\n", err);
        return 1;
    }
    /* the compensated run: the actuator continues from its true state; a
     * second actuator with the same past takes the virgin compensator's
     * voltages */
    MfcbeamModelHandle *twin = mfcbeam_model_from_json(MODEL, err, sizeof err);
    for (int k = 0; k <= 2000; k++) mfcbeam_model_step(twin, 450.0 * (1.0 - fabs(k - 1000.0) / 1000.0));
    for (int k = 0; k < WINDOW; k++) mfcbeam_model_step(twin, u[k]);
    double tracking = 0.0, tracking_virgin = 0.0, identity = 0.0, scale = 0.0;
    for (int k = 0; k < RUN; k++) {
        double target = 120.0 * sin(2.0 * PI * 1.5 * k * 0.0002) + 40.0 * sin(2.0 * PI * 7.0 * k * 0.0002);
        int32_t flags = 0;
        double v = mfcbeam_compensator_compensate(comp, target, &flags);
        double v_virgin = mfcbeam_compensator_compensate(virgin, target, &flags);
        tracking = fmax(tracking, fabs(mfcbeam_model_step(actuator, v) - target));
        tracking_virgin = fmax(tracking_virgin, fabs(mfcbeam_model_step(twin, v_virgin) - target));
        identity = fmax(identity, fabs(mfcbeam_model_step(model, v) - target));
        scale = fmax(scale, fabs(target));
    }
    printf("tracking error after the start-up: %.3g V from the estimated memory, %.3g V from the virgin state\n",
           tracking, tracking_virgin);
    printf("W[W^-1[y]] - y from the estimated state: %.3g V (targets up to %.3g V)\n", identity, scale);
    /* the identity to rounding: a thousand roundings of the targets' size */
    int ok = tracking < 0.1 * tracking_virgin && identity <= 1e3 * DBL_EPSILON * scale;
    printf("%s\n", ok ? "ok" : "FAILED");
    mfcbeam_string_free(estimated);
    mfcbeam_compensator_free(comp);
    mfcbeam_compensator_free(virgin);
    mfcbeam_model_free(model);
    mfcbeam_model_free(actuator);
    mfcbeam_model_free(twin);
    return !ok;
}
