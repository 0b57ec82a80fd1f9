/* lua_taylor.h - Taylor's method on a recorded system for Lua (ode/taylor.h,
 * mech_graph.h's nz_recording_motion_series): functions added to core.mech. */
#ifndef NZ_LUA_TAYLOR_H
#define NZ_LUA_TAYLOR_H
#include <lua.h>

struct nz_stepper;

/* Taylor's method on the system at stack index 1 (its definition table),
 * configured by the table at cfg (rtol, atol or tol, order; orders and
 * linear, the constraints' classification): the integrator of
 * core.mech.ode_new{method = "taylor"}.  Raises when the method does not
 * apply (a system not recorded, a piece that fell back to Lua, branches on
 * the state, constraints of order 3 or more) or the options are wrong;
 * fname names the caller in the messages. */
struct nz_stepper *nz_lua_taylor_new(lua_State *L, int cfg, const char *fname);

/* Raise the failure of a Taylor integrator's last call (status: its
 * status), the system's definition table at 1: a failed solve of the
 * accelerations as the GSL steppers raise it; a step that failed (the
 * series, or the step size) as the table { taylor_stop = "series" |
 * "step", message = ... } that simulate.lua words with the user's line. */
int nz_lua_taylor_raise(lua_State *L, struct nz_stepper *st, int status);

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_taylor(lua_State *L);

#endif
