/*
 * The C functions' names before 0.2, which the header keeps one release as
 * deprecated aliases: each old name gives what its new name gives. Built
 * with -Wno-error=deprecated-declarations (every call here warns).
 */
#include <stdio.h>

#include "mfcbeam.h"

static const double THRESHOLDS[3] = {0.0, 100.0, 200.0};
static const double WEIGHTS[3] = {0.5, 0.2, 0.1};

static int failed = 0;

static void same(const char *what, double a, double b, int fa, int fb) {
  if (a != b || fa != fb) {
    printf("FAILED: %s: %g (flags %d) against %g (flags %d)\n", what, a, fa, b, fb);
    failed++;
  } else {
    printf("ok: %s\n", what);
  }
}

int main(void) {
  const MfcbeamParameters p = {
      .sample_time = 1e-3,
      .hysteresis_thresholds = THRESHOLDS,
      .hysteresis_weights = WEIGHTS,
      .hysteresis_len = 3,
  };
  char err[160];
  MfcbeamCompensatorStorageF32 a32, b32;
  MfcbeamCompensatorStorageF64 a64, b64;
  if (mfcbeam_compensator_f32_init(&a32, &p, -100.0, 100.0, err, sizeof err) ||
      mfcbeam_compensator_f32_init(&b32, &p, -100.0, 100.0, err, sizeof err) ||
      mfcbeam_compensator_f64_init(&a64, &p, -100.0, 100.0, err, sizeof err) ||
      mfcbeam_compensator_f64_init(&b64, &p, -100.0, 100.0, err, sizeof err)) {
    printf("init: %s\n", err);
    return 2;
  }
  const char *json = "{\"sample_time\": 1e-3, \"hysteresis\": {\"thresholds\": [0, 100, 200], "
                     "\"weights\": [0.5, 0.2, 0.1]}}";
  MfcbeamCompensatorHandle *ah = mfcbeam_compensator_from_json(json, -100.0, 100.0, err, sizeof err);
  MfcbeamCompensatorHandle *bh = mfcbeam_compensator_from_json(json, -100.0, 100.0, err, sizeof err);
  if (!ah || !bh) {
    printf("from_json: %s\n", err);
    return 2;
  }
  const double targets[4] = {10.0, 90.0, -40.0, 300.0};
  const float targets32[4] = {10.0f, 90.0f, -40.0f, 300.0f};
  for (int k = 0; k < 4; k++) {
    int fa = 0, fb = 0;
    same("mfcbeam_compensate_f32", mfcbeam_compensate_f32(&a32, targets32[k], &fa),
         mfcbeam_compensator_f32_compensate(&b32, targets32[k], &fb), fa, fb);
    same("mfcbeam_compensate_f64", mfcbeam_compensate_f64(&a64, targets[k], &fa),
         mfcbeam_compensator_f64_compensate(&b64, targets[k], &fb), fa, fb);
    same("mfcbeam_compensate", mfcbeam_compensate(ah, targets[k], &fa),
         mfcbeam_compensator_compensate(bh, targets[k], &fb), fa, fb);
  }
  double ua[4], ub[4];
  float va[4], vb[4];
  int fa[4], fb[4];
  int ra = mfcbeam_compensate_into(ah, targets, ua, fa, 4);
  int rb = mfcbeam_compensator_compensate_into(bh, targets, ub, fb, 4);
  same("mfcbeam_compensate_into", ua[3], ub[3], ra, rb);
  ra = mfcbeam_compensate_f64_into(&a64, targets, ua, fa, 4);
  rb = mfcbeam_compensator_f64_compensate_into(&b64, targets, ub, fb, 4);
  same("mfcbeam_compensate_f64_into", ua[3], ub[3], ra, rb);
  ra = mfcbeam_compensate_f32_into(&a32, targets32, va, fa, 4);
  rb = mfcbeam_compensator_f32_compensate_into(&b32, targets32, vb, fb, 4);
  same("mfcbeam_compensate_f32_into", va[3], vb[3], ra, rb);
  mfcbeam_compensator_free(ah);
  mfcbeam_compensator_free(bh);
  printf("%d failed\n", failed);
  return failed != 0;
}
