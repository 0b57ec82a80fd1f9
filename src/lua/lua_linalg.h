/* lua_linalg.h - least squares and singular values for Lua (linalg.h): functions added to core.mech. */
#ifndef NZ_LUA_LINALG_H
#define NZ_LUA_LINALG_H
#include <lua.h>

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_linalg(lua_State *L);

#endif
