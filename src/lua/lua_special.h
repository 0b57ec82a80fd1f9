/* lua_special.h - GSL special functions for references (field "special"). */
#ifndef NZ_LUA_SPECIAL_H
#define NZ_LUA_SPECIAL_H
#include <lua.h>

void nz_lua_open_special(lua_State *L);

#endif
