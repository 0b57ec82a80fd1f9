/* lua_series.h - constraints of order >= 3 for Lua (constrained_series.h): functions added to core.mech. */
#ifndef NZ_LUA_SERIES_H
#define NZ_LUA_SERIES_H
#include <lua.h>

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_series(lua_State *L);

#endif
