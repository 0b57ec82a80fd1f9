/* lua_util.h - the helpers every binding shares: reading arguments, pushing
 * results, a state in a message, the interrupt object, and the errors raised
 * with the state.  It depends on no other binding (lua_util.c calls none);
 * the bindings include it rather than each other. */
#ifndef NZ_LUA_UTIL_H
#define NZ_LUA_UTIL_H
#include <stddef.h>
#include <lua.h>
#include <lauxlib.h>
#include "core/linalg.h"         /* nz_solve_info */
#include "mech/constrained.h"    /* nz_accel_report */

/* Shortest round-trip text of a number; NaN and infinities the same way on
 * every C library (not "-nan"). */
void nz_lua_fmt_num(char *buf, size_t n, double v);

/* Where in the user's code: the library's own chunks ("@lua/nz/NAME.lua",
 * or .../lua/nz/NAME.lua from a checkout), and "file:line:" of the innermost
 * frame from `level` on that is the user's Lua code (not C, not the
 * library), or "" (nz/base/where.lua's user_where, for C). */
int nz_lua_library_source(const char *source);
void nz_lua_user_location(lua_State *L, int level, char *where, size_t n);
/* Raise the message on top of the stack with the user's "file:line: " first
 * (unless it already starts so), and luaL_error's equivalent: the one way
 * the bindings raise an error about the user's input or state. */
int nz_lua_raise_located(lua_State *L);
int nz_lua_error(lua_State *L, const char *fmt, ...);

/* Arguments and results. */
/* Read k finite numbers from the table at idx (nil gives zeros if allow_nil). */
/* The same without raising: 1 when idx is a plain table (no metatable) of
 * exactly k finite numbers (not strings), read into v; else 0.  For the
 * fast path of a method whose Lua side checks the arguments only when this
 * refuses them, to say what is wrong. */
int nz_lua_try_vector(lua_State *L, int idx, int k, double *v);
void nz_lua_read_vector(lua_State *L, int idx, int k, double *v, const char *what, int allow_nil,
                        const char *fname);
void nz_lua_push_vector(lua_State *L, const double *v, int k);
/* The metatable called name, with gc as its __gc, made when it is not yet
 * in the registry (the userdata types that own C memory). */
void nz_lua_gc_metatable(lua_State *L, const char *name, lua_CFunction gc);
/* The number in field name of the table at idx, dflt when it is nil (a
 * configuration table the library's Lua side built and checked). */
double nz_lua_field_number(lua_State *L, int idx, const char *name, double dflt);
/* The list at idx (a table) as n ints into v: integers, or booleans read
 * as 1 and 0 (the constraints' orders and linear flags as sys:simulate
 * classifies them); an internal error naming what when one is missing.
 * nz_lua_field_ints reads the list in field name of the table at idx. */
void nz_lua_read_ints(lua_State *L, int idx, int n, int *v, const char *what);
void nz_lua_field_ints(lua_State *L, int idx, const char *name, int n, int *v);
void nz_lua_push_matrix(lua_State *L, const double *M, int k);
/* Arguments 2, 3, 4: t, q, qd (nil qd: zeros). */
void nz_lua_read_tq_qd(lua_State *L, int k, double *t, double *q, double *qd, const char *fname);
/* def.name of the definition table at def, or "unnamed". */
const char *nz_lua_system_name(lua_State *L, int def);

/* " at t = .., q = {..}, qd = {..}" added to a message. */
void nz_lua_add_state(luaL_Buffer *msg, double t, const double *q, const double *qd, int k);

/* The interrupt object (nz.interrupted): pushed, recognised by identity, raised. */
void nz_lua_push_interrupt(lua_State *L);
int nz_lua_is_interrupt(lua_State *L, int idx);
int nz_lua_raise_interrupt(lua_State *L);

/* Errors raised with the system's name and the state (the failure of a user
 * function is raised by nz_lua_raise_core, lua_system.h: it reads the Lua
 * evaluator's record). */
int nz_lua_raise_singular_mass(lua_State *L, int def, double t, const double *q, const double *qd,
                               int k, const nz_solve_info *info);
int nz_lua_raise_accel_failure(lua_State *L, int def, const nz_accel_report *rep, const int *orders,
                               double t, const double *q, const double *qd, int k, int nc);

#endif
