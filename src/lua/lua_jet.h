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

/* The call of a function or metamethod `name` on nargs arguments (stack
 * 1..nargs) handed to another number type among them: a table whose
 * metatable has the field, else (when userdata != 0) a full userdata other
 * than a jet that has it.  Returns 1 and leaves its one result, or 0. */
int nz_lua_dispatch(lua_State *L, int nargs, const char *name, int userdata);

/* Raise the error of a failed jet operation, worded as the jets word it:
 * an operand of ops[] that is not finite is named first, else the status
 * with the argument values v, v2. */
int nz_lua_jet_raise(lua_State *L, nz_status st, const char *fname, const nz_jet *const *ops,
                     int nops, double v, double v2);

#endif
