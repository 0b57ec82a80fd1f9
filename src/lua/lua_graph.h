/* lua_graph.h - the Lua face of recorded graphs (userdata "nz.recording"). */
#ifndef NZ_LUA_GRAPH_H
#define NZ_LUA_GRAPH_H
#include <lua.h>
#include "mech/mech_graph.h"

#define NZ_RECORDING_METATABLE "nz.recording"

/* Add recording_new to the table on top (core.mech). */
void nz_lua_open_graph(lua_State *L);
/* The recording at idx, or NULL. */
nz_recording *nz_lua_torecording(lua_State *L, int idx);

#endif
