/* lua_variational.h - variational integrators (ode/variational.h) for Lua:
 * the integrator of core.mech.ode_new{method = "variational"} and the
 * errors of its steps. */
#ifndef NZ_LUA_VARIATIONAL_H
#define NZ_LUA_VARIATIONAL_H
#include <lua.h>
#include "lua/lua_system.h"

struct nz_stepper;

/* The variational integrator for the system at stack index 1 (its
 * definition table), configured by the table at cfg: order (2, 4, 6, 8),
 * verlet (the Stormer-Verlet form applies: lua/nz/motion/variational.lua
 * read it off the recording), orders and linear (the constraints'
 * classification, all 0), and the solves' options (rcond_min, newton_tol,
 * newton_maxit).  Raises when it does not apply (constraints not
 * holonomic, contacts) or the options are wrong. */
struct nz_stepper *nz_lua_variational_new(lua_State *L, int cfg);

/* Raise the failure of its last call (status: its status) in the call
 * that bound the system b (its definition table at 1): a failed solve of q''
 * as the GSL steppers raise it, a user function's error as its own (the
 * evaluator of b kept it), else what did not converge, with the time and
 * the state. */
int nz_lua_variational_raise(lua_State *L, bound_system *b, struct nz_stepper *st, int status);

#endif
