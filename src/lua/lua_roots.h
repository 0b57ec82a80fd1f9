/* lua_roots.h - GSL's root finding for Lua (lua_roots.c): functions added to core.mech. */
#ifndef NZ_LUA_ROOTS_H
#define NZ_LUA_ROOTS_H
#include <lua.h>

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_roots(lua_State *L);

#endif
