/* taylor_motion.h - Taylor's method for the motion of a mechanical system:
 * the integrator of taylor.h given the series of the motion through the
 * system's series hook (mech.h; the recorded graphs of mech_graph.h), free,
 * under constraints of order <= 2, or in the current mode of unilateral
 * contacts (contact.h), and q'' at the output points by the same solve the
 * GSL steppers use (motion_accel.h).  The binding (lua/lua_taylor.c) checks
 * what the method refuses and reports its failures; nothing here knows
 * Lua or the recording.
 *
 * Under constraints each step's series starts from the accelerations and
 * multipliers solved at its start (nz_motion_accel: Newton where a
 * constraint is not linear in q''), and each step's end is checked for a
 * constraint whose gradient passed through zero in it
 * (nz_constraint_row_reversed; not across the changes of a contact mode,
 * each of which restarts the rows). */
#ifndef NZ_TAYLOR_MOTION_H
#define NZ_TAYLOR_MOTION_H

#include "mech/motion_accel.h"
#include "ode/taylor.h"

typedef struct nz_taylor_motion_config {
  nz_motion_setup setup;     /* k, nc, the constraints' classification (orders  */
                             /* of 0, 1, 2), the contacts, the solves' options  */
  double rtol, atol;         /* as taylor.h                                     */
  int order;                 /* 0: from the tolerance                           */
} nz_taylor_motion_config;

/* The integrator (stepper.h), its workspace allocated here; the arrays of
 * the setup are copied.  NULL: no memory or a bad configuration. */
nz_stepper *nz_taylor_motion_new(const nz_taylor_motion_config *cfg);

/* The series a_0 .. a_p of the motion from (t0, q0, qd0) as a step of st
 * takes it (for a caller that wants the coefficients themselves). */
int nz_taylor_motion_series(nz_stepper *st, const nz_system *s, double t0, const double *q0, const double *qd0, int p,
                            double *a);

/* After a failure of st whose cause was a solve of the motion (the start
 * of a series, an output point's q''): its outcome, and where (t, q, qd,
 * the stepper's); NULL when the last failure was not one. */
const nz_motion_outcome *nz_taylor_motion_failure(nz_stepper *st, double *t, const double **q, const double **qd);

/* The setup st was made with (its own copy). */
const nz_motion_setup *nz_taylor_motion_setup(nz_stepper *st);

#endif
