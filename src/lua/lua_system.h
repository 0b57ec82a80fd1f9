/* lua_system.h - the Lua face of the mechanics (core table field "mech"). */
#ifndef NZ_LUA_SYSTEM_H
#define NZ_LUA_SYSTEM_H
#include <lua.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "core/linalg.h"
#include "mech/mech.h"
#include "lua/lua_util.h"   /* the shared helpers, for the bindings that bind a system */

/* Add the mechanics functions to the table on top (core.mech; lua_nz.c only). */
void nz_lua_open_system(lua_State *L);

/* The Lua evaluator behind nz_evaluator: calls the functions of the
 * definition table at stack index `def` under lua_pcall. */
typedef struct lua_evaluator {
  lua_State *L;
  int def;                 /* stack index of the definition table */
  int k;
  char where[256];         /* the user's "file:line:" of the last failure */
  int interrupted;         /* a user function was stopped by the interrupt */
  int passthrough;         /* the failure is the engine's own error from a  */
                           /* call nested in the user's function: raised as */
                           /* it is (its state once, not once per level)     */
} lua_evaluator;

/* A system bound to its definition table for the duration of one call.
 * With a recording (def.recording), the pieces it holds are evaluated on
 * their graphs in C and the others by the Lua evaluator. */
typedef struct bound_system {
  nz_system sys;
  lua_evaluator ev;
  struct nz_recording *comp;   /* NULL: every piece in Lua */
} bound_system;

void nz_lua_bind_system(lua_State *L, int def, bound_system *b);
/* The head of a binding f(def, t, q, qd, ...) of nargs arguments (those
 * missing read as nil): bind the system at 1 and read t, q, qd (2, 3, 4)
 * into a new buffer left on the stack, q then qd, with room after them for
 * nvec more vectors and then nmat matrices of the system's size. */
double *nz_lua_bind_tq_qd(lua_State *L, int nargs, bound_system *b, int nvec, int nmat, double *t,
                          const char *fname);
/* Raise the error of a failed core call, with the system's name; a failed
 * user function's error (kept by the evaluator) starts with the user's
 * file:line. */
int nz_lua_raise_core(lua_State *L, bound_system *b, int st, const char *fname);

#endif
