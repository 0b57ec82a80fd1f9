/* taylor.h - Taylor's method for the motion of a mechanical system (issue
 * 11): the series function gives the motion's coefficients, free or under
 * constraints (mech_graph.h), this loop does not know which.
 *
 * A step from (t, q, q') takes the series of the motion q(t + tau) =
 * sum_{n=0..p+1} a_n tau^n from a series function (for a recorded system
 * nz_compiled_motion_series, mech_graph.h), chooses the step size from the
 * last coefficients (Jorba and Zou 2005, see taylor.c) and moves to the
 * polynomial's value and derivative at the step.  The polynomial is also the
 * dense output: the points of the output grid inside a step are evaluated on
 * it (Horner), so the grid never limits the steps.  No step is rejected:
 * the step size is the one the series predicts to meet the tolerance.
 *
 * The order is p = ceil(-ln(eps) / 2 + 1), eps the tolerance the step
 * needs (see taylor.c for the mix of relative and absolute tolerances).
 *
 * Plain C: no Lua, no printing; statuses from core/status.h.  A run
 * allocates its workspace once (nz_taylor_run) and nothing per step. */
#ifndef NZ_TAYLOR_H
#define NZ_TAYLOR_H

#include "core/status.h"

/* The series of the motion: a[n k + i] = coefficient n of q_i(t0 + tau),
 * n = 0 .. p (a holds (p + 1) k values); an nz status. */
typedef int (*nz_taylor_series_fn)(void *ctx, double t0, const double *q0, const double *qd0, int p,
                                   double *a);

/* Called after each step's series is known and before its grid points are
 * written: the step goes from t to t + h on q(t + tau) = sum_{n=0..P} a[n k
 * + i] tau^n.  *cut comes in as h; setting it to a tau in [0, h) ends the
 * run at t + tau (stop NZ_TAYLOR_CUT: an event that stops the run).  A
 * status other than NZ_OK fails the run (NZ_TAYLOR_HOOK). */
typedef int (*nz_taylor_step_fn)(void *ctx, double t, double h, int k, int P, const double *a, double *cut);

typedef struct nz_taylor_config {
  double t0, t1, dt;     /* the output grid: t0 + i dt, the last point at t1 (t1 > t0) */
  double rtol, atol;     /* >= 0, not both 0 (see taylor.c for the norm)   */
  int order;             /* 0: from the tolerance; else this order (2 ..)   */
  unsigned long max_steps;   /* 0: no limit                                 */
  nz_taylor_step_fn on_step; /* NULL: none                                  */
  void *step_ctx;
} nz_taylor_config;

typedef struct nz_taylor_stats {
  unsigned long steps;       /* steps taken (none is rejected)              */
  unsigned long nseries;     /* calls of the series function                */
  int order;                 /* the highest order used                      */
  double hmin, hmax;         /* the shortest and the longest step (the last,
                              * cut at t1, not counted unless it is the only one) */
  double t;                  /* where the run stopped (t1 when it is done)   */
} nz_taylor_stats;

/* Why a run stopped before t1 (beside the status it returns). */
typedef enum nz_taylor_stop {
  NZ_TAYLOR_DONE = 0,
  NZ_TAYLOR_SERIES,          /* the series function failed: its status       */
  NZ_TAYLOR_STEP,            /* the step size is not positive and finite, or
                              * t + h == t (NZ_ERANGE)                        */
  NZ_TAYLOR_MAX_STEPS,       /* max_steps reached (NZ_ERANGE)                 */
  NZ_TAYLOR_INTERRUPTED,     /* the interrupt was requested (NZ_OK)           */
  NZ_TAYLOR_CUT,             /* on_step cut the step: the run ends there (NZ_OK) */
  NZ_TAYLOR_HOOK             /* on_step failed: its status                    */
} nz_taylor_stop;

/* q(tau) and q'(tau) of a step's polynomial a_0 .. a_P (Horner); q and qd must not
 * overlap a. */
void nz_taylor_eval(int k, int P, const double *a, double tau, double *q, double *qd);

/* Points of the output grid of cfg (t0 .. t1 included); 0 for a bad grid. */
long nz_taylor_grid_count(const nz_taylor_config *cfg);

/* The order Jorba and Zou give for a tolerance eps (0 < eps < 1), >= 2. */
int nz_taylor_order(double eps);

/* Integrate k coordinates from (cfg->t0, q0, qd0) to cfg->t1; tout, qout
 * and qdout receive the grid's points (nz_taylor_grid_count of them; t,
 * then k values of q and of q' per point).  Points already written stay
 * written when the run stops early (*npoints says how many).  Returns NZ_OK
 * (also when interrupted: *stop says so), NZ_EDOM for a bad configuration,
 * NZ_ENOMEM, the series function's status, or NZ_ERANGE (see
 * nz_taylor_stop). */
int nz_taylor_run(int k, nz_taylor_series_fn series, void *ctx, const nz_taylor_config *cfg,
                  const double *q0, const double *qd0, double *tout, double *qout, double *qdout,
                  long *npoints, nz_taylor_stats *stats, nz_taylor_stop *stop);

#endif
