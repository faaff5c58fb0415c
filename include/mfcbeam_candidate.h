/* The step ABI: a compensator W^-1, a model W or an inverse H^-1 in C, as
 * a candidate of `mfcbeam conform --library` and `mfcbeam bench --library`
 * (docs/FILES.md, "The step ABI"). Implement these in a shared library;
 * the prefix `mfcbeam_candidate` may be another (`--symbol-prefix`).
 * The library runs in a host process of its own: a crash, an exit or a
 * hang in it is a finding, not the checker's end. */
#ifndef MFCBEAM_CANDIDATE_H
#define MFCBEAM_CANDIDATE_H

#ifdef __cplusplus
extern "C" {
#endif

/* A new instance for the model file `model_file` (NULL when the caller
 * checks a fixed implementation, whose parameters are compiled in), with a
 * compensator's saturation limits (+-INFINITY for none, and for the other
 * kinds). NULL refuses the model. */
void *mfcbeam_candidate_create(const char *model_file, double lower_limit, double upper_limit);

/* One sample: u = W^-1[y_d], y = W[u] or u = H^-1[y]. With `--precision
 * f32` the step is `float mfcbeam_candidate_step(void *, float)`. */
double mfcbeam_candidate_step(void *candidate, double input);

/* Optional: whether the last step of a compensator was clipped (else the
 * checker takes u at a limit as clipped). */
int mfcbeam_candidate_saturated(const void *candidate);

void mfcbeam_candidate_free(void *candidate);

#ifdef __cplusplus
}
#endif

#endif
