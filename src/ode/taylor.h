/* taylor.h - Taylor's method for the motion of a mechanical system, one of
 * the implementations of the integrator interface
 * (stepper.h): the series function gives the motion's coefficients, free or
 * under constraints (mech_graph.h), the stepper does not know which.
 *
 * A step from (t, q, q') takes the series of the motion q(t + tau) =
 * sum_{n=0..p+1} a_n tau^n from a series function (for a recorded system
 * nz_recording_motion_series, mech_graph.h), chooses the step size from the
 * last coefficients (Jorba and Zou 2005, see taylor.c) and moves to the
 * polynomial's value and derivative at the step.  The polynomial is also the
 * dense output: the stepping loop (ode_run.c) reads the output points inside
 * a step from it (Horner), so the grid never limits the steps, and locates
 * events on it.  No step is rejected: the step size is the one the series
 * predicts to meet the tolerance.
 *
 * The order is p = ceil(-ln(eps) / 2 + 1), eps the tolerance the step
 * needs (see taylor.c for the mix of relative and absolute tolerances).
 *
 * Plain C: no Lua, no printing; statuses from core/status.h.  The stepper
 * allocates its workspace once (nz_taylor_stepper_new) and nothing per step. */
#ifndef NZ_TAYLOR_H
#define NZ_TAYLOR_H

#include "core/status.h"
#include "mech/mech.h"
#include "ode/stepper.h"

/* The series of the motion: a[n k + i] = coefficient n of q_i(t0 + tau),
 * n = 0 .. p (a holds (p + 1) k values), for the system s bound for this
 * call; an nz status. */
typedef int (*nz_taylor_series_fn)(void *ctx, const nz_system *s, double t0, const double *q0, const double *qd0,
                                   int p, double *a);
/* q'' and lambda (k + nc values) at (t, q, q'), for the output points; an
 * nz status (the ctx keeps the details of a failure). */
typedef int (*nz_taylor_accel_fn)(void *ctx, const nz_system *s, double t, const double *q, const double *qd,
                                  double *out);

typedef struct nz_taylor_config {
  int k, nc;             /* coordinates, constraints (the state is (q, q'))  */
  double rtol, atol;     /* >= 0, < 1, not both 0 (see taylor.c for the norm) */
  int order;             /* 0: from the tolerance; else this order (2 ..)   */
  nz_taylor_series_fn series;
  nz_taylor_accel_fn accel;
  /* NULL, or a look at each step's end state: nonzero (1 + a constraint
   * whose gradient passed through zero in the step) is recorded, once, in
   * the statistics (stepper.h's reversed); the step is taken all the same */
  int (*check)(void *ctx, const nz_system *s, double t, const double *q, const double *qd);
  void *ctx;             /* of all three                                     */
  void (*ctx_free)(void *ctx);   /* called when the stepper is freed (NULL: none) */
} nz_taylor_config;

/* What the last failed call of the stepper failed on. */
typedef enum nz_taylor_failure {
  NZ_TAYLOR_OK = 0,
  NZ_TAYLOR_SERIES,          /* the series function: its status               */
  NZ_TAYLOR_STEP,            /* the step size is not positive and finite, or
                              * t + h == t (NZ_ERANGE)                        */
  NZ_TAYLOR_ACCEL            /* the accel function (an output point's q'')    */
} nz_taylor_failure;

/* The increments of a step's polynomial a_0 .. a_P (P >= 2) over tau:
 * dq = q(tau) - a_0 and dqd = q'(tau) - a_1 (Horner); dq and dqd must not
 * overlap a. */
void nz_taylor_increments(int k, int P, const double *a, double tau, double *dq, double *dqd);

/* The order Jorba and Zou give for a tolerance eps (0 < eps < 1), >= 2. */
int nz_taylor_order(double eps);

/* Taylor's method behind the integrator interface (stepper.h): name
 * "taylor", no fixed steps, dense output on each step's polynomial (exact:
 * exact_dense = 1), no rejected steps; stats.nfev counts the series
 * computed (one per step), stats.order the highest order used.  Its
 * workspace (the polynomial of a step of the highest order) is allocated
 * here, once.  NULL: a bad configuration or no memory (ctx is then the
 * caller's to free). */
nz_stepper *nz_taylor_stepper_new(const nz_taylor_config *cfg);

/* After a call of the stepper failed: on what, with which status, at which
 * time and state (dim values, owned by the stepper). */
nz_taylor_failure nz_taylor_last_failure(const nz_stepper *st, int *status, double *t, const double **y);

/* The ctx of its configuration (the series and accel functions'). */
void *nz_taylor_ctx(const nz_stepper *st);

/* The shortest and the longest step taken (the last, cut at the limit
 * time, not counted unless it is the only one). */
void nz_taylor_step_sizes(const nz_stepper *st, double *hmin, double *hmax);

#endif
