/* lua_system.h - the Lua face of the mechanics (core table field "mech"). */
#ifndef NZ_LUA_SYSTEM_H
#define NZ_LUA_SYSTEM_H
#include <lua.h>

/* Add the table of mechanics functions as field "mech" of the table on top. */
void nz_lua_open_system(lua_State *L);

#endif
