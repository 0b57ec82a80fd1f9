/* lua_sweep.h - worker processes for nz.sweep (lua_sweep.c): functions added to core.mech. */
#ifndef NZ_LUA_SWEEP_H
#define NZ_LUA_SWEEP_H
#include <lua.h>

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_sweep(lua_State *L);

#endif
