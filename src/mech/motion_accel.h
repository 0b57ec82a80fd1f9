/* motion_accel.h - which solve gives q'' (and the multipliers) at a state
 * of the motion: the one choice every integrator makes the same way (ode.c
 * for GSL's steppers, ode/taylor_motion.c for Taylor's method), so that a
 * run's output points hold the same accelerations whatever the method.
 *
 *   contacts      the contacts' mode (contact.h: nz_contacts_accel)
 *   free          M q'' + h = 0 (mech.h: nz_accel, the system's accel hook)
 *   constraints   (6.2) with the constraints at the acceleration level
 *                 (constrained.h: nz_accel_constrained, Newton where a
 *                 constraint is not linear in q''), from the caller's guess
 *                 of (q'', lambda) when it gives one: the last root, which
 *                 keeps the run on its branch.
 *
 * Constraints of order >= 3 hold q'' in the state (constrained_series.h);
 * their integrators read it there and do not ask this. */
#ifndef NZ_MOTION_ACCEL_H
#define NZ_MOTION_ACCEL_H

#include "core/linalg.h"
#include "mech/constrained.h"
#include "mech/mech.h"

struct nz_contacts;

/* What the motion is: k coordinates, nc constraints with their
 * classification (orders and linear, NULL when nc is 0), the contacts (NULL:
 * none) and the solves' options. */
typedef struct nz_motion_setup {
  int k, nc;
  const int *orders, *linear;
  struct nz_contacts *contacts;
  nz_accel_options opt;
} nz_motion_setup;

typedef enum nz_motion_failed {
  NZ_MOTION_OK = 0,
  NZ_MOTION_FAILED_MASS,          /* M singular or not positive definite: mass says how */
  NZ_MOTION_FAILED_CONSTRAINTS,   /* the constrained solve failed: rep says how         */
  NZ_MOTION_FAILED_CONTACTS       /* the contacts' mode (their own report)              */
} nz_motion_failed;

/* What a solve reports: which kind failed, with its details.  rep.involved
 * (nc ints) and rep.A (nc x k, or NULL) are the caller's buffers. */
typedef struct nz_motion_outcome {
  nz_motion_failed failed;
  nz_accel_report rep;
  nz_solve_info mass;
} nz_motion_outcome;

/* q'' (k values) and lambda (nc values) at (t, q, qd); guess: k + nc values
 * Newton starts from (NULL: its own start).  NZ_OK, or the status of the
 * failed solve (out->failed says which kind, when it is one of the motion's
 * own: a user function's error is only its status). */
int nz_motion_accel(const nz_system *s, const nz_motion_setup *a, double t, const double *q, const double *qd,
                    const double *guess, double *qdd, double *lambda, nz_motion_outcome *out);

#endif
