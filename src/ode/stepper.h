/* stepper.h - the integrator interface of sys:simulate: what
 * the stepping loop (ode_run.h) asks of a method, implemented by GSL's
 * steppers (stepper_gsl.c, over ode.c), by Taylor's method (taylor.c) and by
 * the variational integrators (variational.c).
 *
 * An integrator advances the state y (dim values, q then q' first) one
 * step at a time towards a limit time, and can give the state anywhere
 * inside its last step (dense output), the accelerations and multipliers
 * at a state (for the output points) and its statistics.  It carries no
 * output grid, no events and no projection: those are the loop's.
 *
 *   step        one step from (*t, y) towards tlimit, never past it; *h is
 *               the step to try and, on return, the next one (a method that
 *               chooses its own steps reads nothing from it and returns the
 *               step it took).  NZ_OK, or a failure that leaves *t and y as
 *               they were (the method's own report says what failed).  The
 *               method keeps the time its steps end at as a double-length
 *               sum (core/compensated.h) and hands back its rounded value,
 *               so that 1e8 steps lose nothing to t + h; a step from a time
 *               it did not leave starts that sum afresh.  NULL for a method
 *               with fixed steps only (variational.c).
 *   step_fixed  one step of exactly h; NULL for a method without fixed steps
 *               (the loop, which chose h, keeps the time).
 *   dense       the state at tau in [ta, tb] of the last step: *ok when it
 *               meets the method's tolerance there (an interpolant's error
 *               estimate; always for a method whose dense output is its own
 *               solution), NZ_EARG when tau is not in the last step.
 *   accel       q'' and lambda (k + nc values) at (t, y).
 *   root        the last root q^(p) of a top integrator (k values), or NULL.
 *   stats       steps, rejected steps, the order used, evaluations.
 *   reset       forget the history (a step taken again from an earlier
 *               state, a jump of the state); the statistics stay.
 *   free        release it (NULL-safe through nz_stepper_free).
 *
 * The system s is bound for each call (the Lua binding binds it per call),
 * so an integrator keeps no pointer to it between calls.  Plain C: no Lua,
 * no printing; statuses from core/status.h.  Both implementations allocate
 * their workspaces when they are made and nothing per step. */
#ifndef NZ_STEPPER_H
#define NZ_STEPPER_H

#include "core/status.h"
#include "mech/mech.h"

typedef struct nz_stepper nz_stepper;

typedef struct nz_stepper_stats {
  unsigned long steps;       /* accepted steps                                  */
  unsigned long rejected;    /* rejected by the error control (Taylor: none)    */
  unsigned long nfev;        /* evaluations of the right-hand side, or of the   */
                             /* series of the motion (one per Taylor step)      */
  unsigned long njev;        /* Jacobians (implicit steppers)                   */
  int order;                 /* the order used (the highest so far)             */
  int reversed;              /* 1 + the first constraint whose gradient passed   */
  double reversed_ta, reversed_tb;   /* through zero, in the step (ta, tb); or 0 */
} nz_stepper_stats;

typedef struct nz_stepper_ops {
  int (*step)(nz_stepper *st, const nz_system *s, double *t, double tlimit, double *h, double *y);
  int (*step_fixed)(nz_stepper *st, const nz_system *s, double *t, double h, double *y);
  int (*dense)(nz_stepper *st, const nz_system *s, double tau, double *y, int *ok);
  int (*accel)(nz_stepper *st, const nz_system *s, double t, const double *y, double *out);
  const double *(*root)(const nz_stepper *st);
  void (*stats)(const nz_stepper *st, nz_stepper_stats *out);
  void (*reset)(nz_stepper *st);
  void (*free)(nz_stepper *st);
} nz_stepper_ops;

/* The head of every implementation's object (its first member). */
struct nz_stepper {
  const nz_stepper_ops *ops;
  const char *name;          /* "rk8pd", ..., "taylor"                           */
  int k, nc, dim;
  int exact_dense;           /* dense output is the method's own solution (the   */
                             /* step's polynomial): events are located on it     */
};

static inline void nz_stepper_free(nz_stepper *st)
{
  if (st) st->ops->free(st);
}

/* GSL's steppers: o (ode.h) becomes the stepper's and is freed with it.
 * Dense output is the Hermite interpolant of ode_run.h, its error estimate
 * held to atol + rtol |y_i|.  NULL: no memory (o is freed). */
struct nz_ode;
nz_stepper *nz_stepper_gsl_new(struct nz_ode *o, int k, int nc, double rtol, double atol);
struct nz_ode *nz_stepper_gsl_ode(nz_stepper *st);

#endif
