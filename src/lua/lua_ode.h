/* lua_ode.h - the integrator for Lua (functions added to core.mech). */
#ifndef NZ_LUA_ODE_H
#define NZ_LUA_ODE_H
#include <lua.h>

void nz_lua_open_ode(lua_State *L);

#endif
