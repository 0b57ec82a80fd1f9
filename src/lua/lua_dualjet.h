/* lua_dualjet.h - the state direction of the Lua evaluator (userdata
 * "nz.dualjet"): numbers v + eta d with eta^2 = 0, where v and d are jets
 * (each with its own tangent directions eps_d, whose products with eta are
 * kept).  The arguments of a user function evaluated along a state
 * direction are dualjets; the graph evaluator does the same arithmetic on
 * its nodes (src/graph/graph_jets.c, the eta-part of nz_graph_eval_jets). */
#ifndef NZ_LUA_DUALJET_H
#define NZ_LUA_DUALJET_H

#include <lua.h>
#include "jets/jet.h"

#define NZ_DUALJET_METATABLE "nz.dualjet"

/* Register the type; the table on top of the stack is the core module,
 * whose jet functions (nz_lua_open_jet) the branch functions call, and
 * whose field "mech" gets dualjet(v, d) (for tests). */
void nz_lua_open_dualjet(lua_State *L);

/* Push a new dualjet holding copies of v and d (d NULL: zero of v's shape). */
void nz_lua_push_dualjet(lua_State *L, const nz_jet *v, const nz_jet *d);

/* The parts of the dualjet at idx into *v and *d (pointers into it, valid
 * while it lives); 0 if idx holds no dualjet. */
int nz_lua_todualjet(lua_State *L, int idx, const nz_jet **v, const nz_jet **d);

#endif
