/* mech_jacobian.h - the exact Jacobian of the motion as a first-order ODE,
 * y = (q, q'[, W]), for GSL's implicit steppers. */
#ifndef NZ_MECH_JACOBIAN_H
#define NZ_MECH_JACOBIAN_H

#include "mech/constrained.h"

/* dfdy (dim x dim, row-major) and dfdt (dim) at (t, y), dim = 2k + work.
 * The accelerations a(y) (and multipliers) solve G(a, lambda; y) = 0:
 * d(a, lambda)/dy = -J^-1 dG/dy, where dG/dy comes from one evaluation of
 * the residual and the constraint rows along each state direction (a second
 * infinitesimal on the jets: nz_direction).  No finite differences.  The row
 * of the work W (W' = R_0) is left zero here: ode.c fills it (work_row).
 * opt->guess_* select the root of nonlinear constraints, as in the
 * right-hand side.  Why the solve failed goes where the right-hand side
 * puts it (ode.c), for the same message: without constraints a singular M
 * (NZ_ESINGULAR) fills *mass; with them, *rep (NZ_ESINGULAR or NZ_EARG; the
 * caller's rep->involved and rep->A as nz_accel_constrained's). */
int nz_ode_jacobian(const nz_system *s, const int *orders, const int *linear,
                    const nz_accel_options *opt, int work, double t, const double *y, double *dfdy,
                    double *dfdt, nz_solve_info *mass, nz_accel_report *rep);

#endif
