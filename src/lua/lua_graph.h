/* lua_graph.h - the Lua face of recorded graphs (userdata "nz.compiled"). */
#ifndef NZ_LUA_GRAPH_H
#define NZ_LUA_GRAPH_H
#include <lua.h>
#include "mech/mech_graph.h"

#define NZ_COMPILED_METATABLE "nz.compiled"

/* Add compiled_new to the table on top (core.mech). */
void nz_lua_open_graph(lua_State *L);
/* The compiled system at idx, or NULL. */
nz_compiled *nz_lua_tocompiled(lua_State *L, int idx);

#endif
