/* lua_taylor.h - Taylor's method on a recorded system for Lua (ode/taylor.h,
 * mech_graph.h's nz_compiled_motion_series): functions added to core.mech. */
#ifndef NZ_LUA_TAYLOR_H
#define NZ_LUA_TAYLOR_H
#include <lua.h>

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_taylor(lua_State *L);

#endif
