/* variational_del.h - the discrete Euler-Lagrange equations of the
 * trapezoidal discrete Lagrangian (variational.h) for any Lagrangian
 * L = F - V of the system, with its forces Q and holonomic constraints,
 * solved by Newton's method with the exact Jacobian from the jets: F, V
 * and Q evaluated on dual numbers with a tangent for each q_i and q'_i
 * (their gradients: p = dF/dq', dL/dq) and a state direction on top (one
 * column of the second derivatives), the evaluator interface of mech.h.
 *
 * One step of h from (t0, q0) with the momentum p0, t1 = t0 + h, v = (q1 -
 * q0) / h, g = dF/dq - dV/dq + Q (the generalized force of the Lagrangian
 * and of the forces), G = dPhi/dq, p(t, q, w) = dF/dq'(t, q, w):
 *
 *   p0 = 1/2 [p(t0, q0, v) + p(t1, q1, v)] - h/2 g(t0, q0, v) + G(t0, q0)^T l
 *   Phi(t1, q1) = 0                                     (q1 and l: Newton)
 *   p1 = 1/2 [p(t0, q0, v) + p(t1, q1, v)] + h/2 g(t1, q1, v) - G(t1, q1)^T m
 *   p(t1, q1, w1) = p1,  G(t1, q1) w1 + Phi_t(t1, q1) = 0   (w1 and m: Newton)
 *
 * the first line -D1 L_d - F_d^- = p0 with the force of the discrete
 * Lagrange-d'Alembert principle F_d^-(q0, q1) = h/2 Q(t0, q0, v) (the
 * trapezoidal quadrature of the virtual work, Marsden-West §3.2.1) and the
 * constraint force on q0 (SHAKE); the third the discrete Legendre transform
 * D2 L_d + F_d^+, whose momentum the last line projects onto the
 * constraints' velocity level (RATTLE): w1 is the velocity of the output.
 * The unknowns are the increment q1 - q0 and l (scaled by h/2, a
 * momentum), so that Newton's steps and its stopping rule are relative to
 * the step.  Plain C: statuses from core/status.h; the workspace is
 * allocated once (nz_del_new) and nothing per step. */
#ifndef NZ_VARIATIONAL_DEL_H
#define NZ_VARIATIONAL_DEL_H

#include "mech/mech.h"

typedef struct nz_del nz_del;

/* How a step failed (nz_del_report.what). */
typedef enum nz_del_failure {
  NZ_DEL_OK = 0,
  NZ_DEL_NEWTON,     /* Newton's iterations did not converge                  */
  NZ_DEL_SINGULAR,   /* its matrix is singular: M, or dependent constraints   */
  NZ_DEL_EVAL        /* an evaluation of F, V, Q or a constraint failed       */
} nz_del_failure;

typedef struct nz_del_report {
  nz_del_failure what;
  int velocity;      /* the failure was the velocity's (the last two lines)   */
  int iterations;    /* Newton's iterations of the solve that failed           */
  double residual;   /* its last residual, relative to the size of its terms   */
} nz_del_report;

/* Newton stops when the equations hold to NZ_DEL_TOL of the size of their
 * terms (rounding: they are only known to a few ulps of those), or its
 * residual stalls near there; at most NZ_DEL_MAXIT iterations. */
#define NZ_DEL_TOL (16 * 2.220446049250313e-16)
#define NZ_DEL_MAXIT 40

/* Newton's stopping rule (above) on a residual R of N equations with the
 * size of their terms in size: 1 when done; *last keeps the residual
 * relative to the terms from one iteration to the next (INFINITY at the
 * start).  Shared with the Verlet path's constraint forces (variational.c). */
int nz_del_converged(const double *R, const double *size, int N, double *last);

/* A workspace for k coordinates and nc holonomic constraints (each of
 * which receives nlevels slots, nz_constraint_levels_max); NULL when out
 * of memory. */
nz_del *nz_del_new(int k, int nc, int nlevels);
void nz_del_free(nz_del *d);   /* NULL is harmless */

/* p = dF/dq' at (t, q, w): the continuous Legendre transform. */
int nz_del_momentum(nz_del *d, const nz_system *s, double t, const double *q, const double *w, double *p);

/* The constraints at (t, q): values phi (nc), gradients G (nc x k,
 * row-major) and time partials phit (nc); any pointer but G may be NULL. */
int nz_del_constraints(nz_del *d, const nz_system *s, double t, const double *q, double *phi, double *G, double *phit);

/* One step (the lines at the top): from (t0, q0, p0), Newton from the
 * increment guess (k values); into dq = q1 - q0, dp = p1 - p0 and w1.
 * The evaluations made are added to *nfev, the Jacobians to *njev. */
int nz_del_step(nz_del *d, const nz_system *s, double t0, double h, const double *q0, const double *p0,
                const double *guess, double *dq, double *dp, double *w1, unsigned long *nfev, unsigned long *njev,
                nz_del_report *rep);

#endif
