/* variational.h - variational integrators built from the system's
 * Lagrangian (J. E. Marsden and M. West, "Discrete mechanics and
 * variational integrators", Acta Numerica 10 (2001) 357-514), one of the
 * implementations of the integrator interface (stepper.h): fixed steps only.
 *
 * The motion is the stationary point of a discrete action, the sum of a
 * discrete Lagrangian L_d(q_k, q_k+1) ~ the integral of L over a step; its
 * equations (the discrete Euler-Lagrange equations, variational_del.h)
 * make a symplectic map that conserves the momentum map of every symmetry
 * of L_d exactly (the discrete Noether theorem) and keeps the energy within
 * a bound for exponentially long times (no drift).
 *
 * Order 2: the trapezoidal discrete Lagrangian
 *   L_d(q0, q1) = h/2 [L(t0, q0, v) + L(t1, q1, v)],  v = (q1 - q0) / h
 * (Marsden-West §2.6), rather than the midpoint rule h L((q0 + q1)/2, v):
 * for the commonest systems, a constant mass matrix and forces that do not
 * depend on q' (particles, Cartesian coordinates, Kepler, Henon-Heiles, a
 * pendulum in Cartesian coordinates), its equations are explicit, Stormer
 * and Verlet's scheme with one evaluation of q'' a step, where the
 * midpoint rule needs Newton's method for any nonlinear force; and with
 * holonomic constraints it is SHAKE and RATTLE (Marsden-West §3.5), the
 * constraints held to rounding at every step.  Both are symmetric and of
 * order 2; on the oscillator q'' = -q from q' = 0 the trapezoidal rule
 * gives q_N = cos(N theta) exactly with cos(theta) = 1 - h^2/2 (the
 * midpoint rule (1 - h^2/4)/(1 + h^2/4)).  For any other Lagrangian (a mass
 * matrix that depends on q or t, forces on q') the same equations are
 * implicit and solved by Newton's method with the exact Jacobian from the
 * jets (variational_del.h).  Which applies the caller says (verlet below:
 * lua/nz/motion/variational.lua reads it off the recording).
 *
 * Orders 4, 6, 8: symmetric compositions of the order-2 map with steps
 * gamma_i h, a variational integrator again (of the composed discrete
 * Lagrangian): order 4, Suzuki's five steps (M. Suzuki, Phys. Lett. A 146
 * (1990) 319); 6 and 8, Kahan and Li's nine and seventeen (W. Kahan and
 * R.-C. Li, "Composition constants for raising the orders of
 * unconventional schemes for ordinary differential equations", Math. Comp.
 * 66 (1997) 1089-1099: s9odr6a, s17odr8a).
 *
 * The state the loop sees is (q, q'), q' the discrete Legendre transform's
 * velocity (the momentum's, p = dL/dq'(q, q')); the stepper keeps q and the
 * momentum (the velocity when the mass matrix is constant) to twice the
 * precision (core/compensated.h), and takes them up again when the loop
 * hands back the state it left.  Forces Q enter by the discrete
 * Lagrange-d'Alembert principle; holonomic constraints (order 0) by the
 * constrained discrete equations.  Constraints on q' or q'' and contacts
 * the caller refuses (lua/nz/motion/variational.lua).  Dense output: the
 * cubic Hermite interpolant of (q, q') at the step's ends.
 *
 * Plain C: no Lua, no printing; statuses from core/status.h; the workspace
 * is allocated once and nothing per step. */
#ifndef NZ_VARIATIONAL_H
#define NZ_VARIATIONAL_H

#include "mech/motion_accel.h"
#include "ode/stepper.h"
#include "ode/variational_del.h"

typedef struct nz_variational_config {
  nz_motion_setup setup;     /* k, nc (all holonomic: orders 0), the solves'    */
                             /* options (q'' and lambda at the output points)   */
  int order;                 /* 2, 4, 6 or 8                                    */
  int verlet;                /* 1: the mass matrix is constant and h (of         */
                             /* M q'' + h = 0) does not depend on q': Stormer-   */
                             /* Verlet (RATTLE); 0: Newton on the equations      */
  int nlevels;               /* the slots a constraint receives at most          */
                             /* (nz_constraint_levels_max; 0: the default)       */
} nz_variational_config;

/* The integrator (name "variational", fixed steps only, dense output the
 * Hermite cubic of each step), its workspace allocated here; the setup's
 * arrays are copied.  NULL: no memory or a bad configuration. */
nz_stepper *nz_variational_new(const nz_variational_config *cfg);

/* What the last failed call failed on. */
typedef enum nz_variational_failure {
  NZ_VARIATIONAL_OK = 0,
  NZ_VARIATIONAL_DEL,        /* the discrete equations (the report says how)    */
  NZ_VARIATIONAL_RATTLE,     /* Verlet's constraint forces: Newton (the report)  */
  NZ_VARIATIONAL_MOTION,     /* a solve of q'' (Verlet's, an output point's):    */
                             /* the outcome says which                          */
  NZ_VARIATIONAL_MASS        /* the constant mass matrix of RATTLE is singular   */
} nz_variational_failure;

/* After a failure: on what, with which status, at which time and state
 * (2k values, the stepper's), with the Newton report (DEL, RATTLE) or the
 * solve's outcome (MOTION, MASS: its mass field). */
nz_variational_failure nz_variational_last_failure(const nz_stepper *st, int *status, double *t, const double **y,
                                                   const nz_del_report **del, const nz_motion_outcome **oc);

/* The setup st was made with (its own copy), or NULL when st is not a
 * variational integrator. */
const nz_motion_setup *nz_variational_setup(const nz_stepper *st);

/* The composition of order p: its number of steps and their fractions of
 * h (NULL for an order it does not have). */
const double *nz_variational_gammas(int p, int *stages);

#endif
