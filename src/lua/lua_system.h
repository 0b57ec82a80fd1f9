/* lua_system.h - the Lua face of the mechanics (core table field "mech"). */
#ifndef NZ_LUA_SYSTEM_H
#define NZ_LUA_SYSTEM_H
#include <lua.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "core/linalg.h"
#include "mech/mech.h"

/* Add the table of mechanics functions as field "mech" of the table on top. */
void nz_lua_open_system(lua_State *L);

/* The Lua evaluator behind nz_evaluator: calls the functions of the
 * definition table at stack index `def` under lua_pcall. */
typedef struct lua_evaluator {
  lua_State *L;
  int def;                 /* stack index of the definition table */
  int k;
  char where[256];         /* the user's "file:line:" of the last failure */
  int interrupted;         /* a user function was stopped by the interrupt */
} lua_evaluator;

/* A system bound to its definition table for the duration of one call.
 * With a recording (def.compiled), the pieces it holds are evaluated on
 * their graphs in C and the others by the Lua evaluator. */
typedef struct bound_system {
  nz_system sys;
  lua_evaluator ev;
  struct nz_compiled *comp;   /* NULL: every piece in Lua */
} bound_system;

void nz_lua_bind_system(lua_State *L, int def, bound_system *b);
const char *nz_lua_system_name(lua_State *L, int def);
/* Read k finite numbers from the table at idx (nil gives zeros if allow_nil). */
void nz_lua_read_vector(lua_State *L, int idx, int k, double *v, const char *what, int allow_nil,
                        const char *fname);
void nz_lua_push_vector(lua_State *L, const double *v, int k);
void nz_lua_push_matrix(lua_State *L, const double *M, int k);
/* Arguments 2, 3, 4: t, q, qd (nil qd: zeros). */
void nz_lua_read_tq_qd(lua_State *L, int k, double *t, double *q, double *qd, const char *fname);
void nz_lua_add_state(luaL_Buffer *msg, double t, const double *q, const double *qd, int k);
/* The interrupt object (nz.interrupted): pushed, recognised by identity, raised. */
void nz_lua_push_interrupt(lua_State *L);
int nz_lua_is_interrupt(lua_State *L, int idx);
int nz_lua_raise_interrupt(lua_State *L);
/* Errors, raised with the system's name and the state. */
int nz_lua_raise_core(lua_State *L, bound_system *b, int st, const char *fname);
int nz_lua_raise_singular_mass(lua_State *L, int def, double t, const double *q, const double *qd,
                               int k, const nz_solve_info *info);
int nz_lua_raise_accel_failure(lua_State *L, int def, const nz_accel_report *rep, const int *orders,
                               double t, const double *q, const double *qd, int k, int nc);

/* The functions of lua_constraints.c and lua_linalg.c, added to core.mech. */
void nz_lua_open_constraints(lua_State *L);
void nz_lua_open_linalg(lua_State *L);
void nz_lua_open_series(lua_State *L);

#endif
