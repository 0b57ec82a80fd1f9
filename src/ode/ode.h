/* ode.h - the motion of a mechanical system as a first-order ODE for GSL's
 * odeiv2 steppers: y = (q, q'[, W]), y' = (q', q''(t, q, q')[, R_0 + Q.q']),
 * where W is the work of moving constraints and of the forces Q
 * (docs/theory.md §9), carried only when asked for.
 *
 * The caller steps it one adaptive (or fixed) step at a time, so that the
 * output grid, events, projection and monitors stay in the caller's hands
 * (lua/nz/motion/simulate.lua, or the loop in C of ode_run.h, which reaches it
 * through the integrator interface: stepper.h, stepper_gsl.c).  Implicit steppers get the exact Jacobian of the
 * first-order system from jets (mech_jacobian.c); at level p >= 3, central
 * differences of the right-hand side (constrained_series.h). */
#ifndef NZ_ODE_H
#define NZ_ODE_H

#include "core/status.h"
#include "mech/constrained.h"
#include "core/linalg.h"               /* nz_solve_info */
#include "mech/mech.h"

typedef struct nz_ode nz_ode;

typedef struct nz_ode_config {
  const char *method;        /* a GSL odeiv2 stepper name: rk8pd, msbdf, ...        */
  double rtol, atol;         /* adaptive control; ignored by fixed steps            */
  double h0;                 /* first step                                          */
  int work;                  /* carry W = integral (R_0 + Q.q') dt                  */
  int nc;                    /* constraints, with their classification:             */
  const int *orders, *linear;
  nz_accel_options accel;    /* including Baumgarte's alpha, beta                   */
  int level;                 /* p >= 3: constraints of order >= 3, the state of     */
                             /* constrained_series.h (no work; the Jacobian by      */
                             /* central differences); else 0                        */
  int top;                   /* with level: a constraint of order p nonlinear in    */
                             /* q^(p); y = (q .. q^(p-1)), (q^(p), lambda) solved   */
  const double *guess;       /* top: Newton's first start (k + nc), or NULL         */
  struct nz_contacts *contacts;  /* unilateral contacts (mech/contact.h), the      */
                             /* caller's: q'' and lambda in their current mode;     */
                             /* the Jacobian by central differences; NULL: none     */
} nz_ode_config;

/* The stepper names accepted, NULL-terminated. */
extern const char *const nz_ode_methods[];
int nz_ode_is_implicit(const char *method);

/* NULL on an unknown method (check nz_ode_methods) or no memory. */
nz_ode *nz_ode_alloc(int k, const nz_ode_config *cfg);
void nz_ode_free(nz_ode *o);
int nz_ode_dim(const nz_ode *o);
/* The constraints' classification it was made with (nc orders). */
const int *nz_ode_orders(const nz_ode *o);
/* The stepper's name, one of nz_ode_methods. */
const char *nz_ode_method(const nz_ode *o);
/* msadams and msbdf: a history of steps, lost by a step taken again from
 * an earlier state (nz_ode_reset first). */
int nz_ode_is_multistep(const nz_ode *o);

/* One adaptive step from *t towards t1 (never past it): *h is the step to
 * try and, on return, the next one.  s: the system, bound for this call.
 * Returns NZ_OK or a failure whose details nz_ode_failure() gives. */
int nz_ode_step(nz_ode *o, const nz_system *s, double *t, double t1, double *h, double *y);
/* One step of exactly h. */
int nz_ode_step_fixed(nz_ode *o, const nz_system *s, double *t, double h, double *y);
/* Forget the history (after a jump of the state, e.g. a projection). */
void nz_ode_reset(nz_ode *o);

/* q'' and lambda at (t, y): out holds k accelerations then nc multipliers. */
int nz_ode_accel(nz_ode *o, const nz_system *s, double t, const double *y, double *out);

/* The last root (q^(p), lambda) of a top integrator (k + nc), or NULL. */
const double *nz_ode_root(const nz_ode *o);

/* The right-hand side f(t, y) (dim values), as the steppers get it. */
int nz_ode_rhs(nz_ode *o, const nz_system *s, double t, const double *y, double *f);

/* The Jacobian at (t, y), as the implicit steppers get it: exact (jets)
 * at the acceleration level, central differences at level p >= 3. */
int nz_ode_jacobian_at(nz_ode *o, const nz_system *s, double t, const double *y, double *dfdy,
                       double *dfdt);

typedef struct nz_ode_stats {
  unsigned long steps, rejected, nfev, njev;
  int order;                 /* the stepper's (msadams, msbdf: its current one) */
  int reversed;              /* 1 + the first constraint whose row reversed in a  */
  double reversed_ta, reversed_tb;   /* step (ta, tb), or 0: see check_gradients  */
} nz_ode_stats;
void nz_ode_get_stats(const nz_ode *o, nz_ode_stats *st);

typedef enum nz_ode_failure_kind {
  NZ_ODE_FAIL_NONE = 0,
  NZ_ODE_FAIL_FUNCTION,      /* a user function failed (evaluator's message) */
  NZ_ODE_FAIL_MASS,          /* singular or indefinite M                      */
  NZ_ODE_FAIL_CONSTRAINTS,   /* see report (singular, Newton, order)          */
  NZ_ODE_FAIL_STEP,          /* step size underflow: no progress               */
  NZ_ODE_FAIL_NONFINITE,     /* the state became NaN or infinite              */
  NZ_ODE_FAIL_CONTACT        /* the contacts' solve (nz_contacts_failure)     */
} nz_ode_failure_kind;

typedef struct nz_ode_failure {
  nz_ode_failure_kind kind;
  int status;                /* the nz status behind it                       */
  double t;                  /* where                                          */
  const double *y;           /* the state there (dim values, owned by o)      */
  nz_solve_info mass;        /* NZ_ODE_FAIL_MASS                               */
  nz_accel_report accel;     /* NZ_ODE_FAIL_CONSTRAINTS                        */
} nz_ode_failure;
const nz_ode_failure *nz_ode_last_failure(const nz_ode *o);

#endif
