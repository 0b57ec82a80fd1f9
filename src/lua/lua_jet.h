/* lua_jet.h - the Lua face of jets (userdata "nz.jet"). */
#ifndef NZ_LUA_JET_H
#define NZ_LUA_JET_H

#include <lua.h>
#include "jets/jet.h"

#define NZ_JET_METATABLE "nz.jet"

/* Register the jet functions into the table on top of the stack. */
void nz_lua_open_jet(lua_State *L);

/* The jet at idx, or a Lua error "bad argument #idx (jet expected)". */
nz_jet *nz_lua_checkjet(lua_State *L, int idx);
nz_jet *nz_lua_tojet(lua_State *L, int idx);        /* NULL if not a jet */
/* Push a new zeroed jet of that shape and return it. */
nz_jet *nz_lua_newjet(lua_State *L, int order, int ntan);

#endif
