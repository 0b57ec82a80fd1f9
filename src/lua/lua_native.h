/* lua_native.h - the cache of machine code for Lua (lua_native.c): nz.cache. */
#ifndef NZ_LUA_NATIVE_H
#define NZ_LUA_NATIVE_H
#include <lua.h>

/* Add the table `cache` to the table on top of the stack, and send the
 * cache's notices to stderr (lua_nz.c only). */
void nz_lua_open_native(lua_State *L);

#endif
