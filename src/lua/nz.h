/* nz.h - what the nzlua program needs of the nz library. */
#ifndef NZ_H
#define NZ_H
#include <lua.h>

#define NZ_VERSION "0.1.0"

int luaopen_nz(lua_State *L);

#endif
