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

/* Workspaces a binding keeps between calls (lua_jet.c, lua_dualjet.c).
 * nz_lua_push_workspace pushes a zeroed userdata of that size whose
 * metatable's __gc is gc (which frees what it points to).  The buffers in it
 * grow on demand (a Lua error "not enough memory ..." if they cannot):
 * nz_lua_jet_work: *w of *wlen doubles, for the kernels of jets of that
 * order; nz_lua_jet_room: *j of *bytes, shaped (order, ntan), its
 * coefficients not set. */
void *nz_lua_push_workspace(lua_State *L, size_t size, lua_CFunction gc);
double *nz_lua_jet_work(lua_State *L, double **w, size_t *wlen, int order);
nz_jet *nz_lua_jet_room(lua_State *L, nz_jet **j, size_t *bytes, int order, int ntan);

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

/* The jets' unary functions as X(name, nz_jet_fn), for the bindings that
 * define a Lua function for each (lua_jet.c, lua_dualjet.c). */
#define NZ_LUA_JET_UNARY(X)                                                         \
  X(exp, NZ_FN_EXP) X(log, NZ_FN_LOG) X(sqrt, NZ_FN_SQRT) X(sin, NZ_FN_SIN)          \
  X(cos, NZ_FN_COS) X(tan, NZ_FN_TAN) X(asin, NZ_FN_ASIN) X(acos, NZ_FN_ACOS)        \
  X(atan, NZ_FN_ATAN) X(sinh, NZ_FN_SINH) X(cosh, NZ_FN_COSH) X(tanh, NZ_FN_TANH)    \
  X(abs, NZ_FN_ABS) X(sign, NZ_FN_SIGN)

/* The binary operations of jets and dualjets, and X(name, op) for each. */
typedef enum nz_lua_binop {
  NZ_OP_ADD, NZ_OP_SUB, NZ_OP_MUL, NZ_OP_DIV, NZ_OP_POW, NZ_OP_ATAN2, NZ_OP_HYPOT
} nz_lua_binop;
#define NZ_LUA_JET_BINARY(X)                                                        \
  X(add, NZ_OP_ADD) X(sub, NZ_OP_SUB) X(mul, NZ_OP_MUL) X(div, NZ_OP_DIV)            \
  X(pow, NZ_OP_POW) X(atan2, NZ_OP_ATAN2) X(hypot, NZ_OP_HYPOT)
/* The jets' name of each in messages, and the field another number type
 * answers to (its metamethod or function). */
extern const char *const nz_lua_binop_names[];
extern const char *const nz_lua_binop_fields[];

#endif
