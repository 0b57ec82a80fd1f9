/* lua_jet.c - binding of the jet engine (jet.h) to Lua.
 *
 * A jet lives whole inside one userdata, so Lua's garbage collector owns its
 * memory.  Every function takes numbers and jets alike: numbers give numbers
 * (with the same domain checks), jets give jets.  All functions and
 * metamethods share one workspace, their first upvalue, so that no operation
 * allocates a temporary besides its result. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "lua/lua_jet.h"

/* ------------------------------------------------------------------ */
/* Workspace                                                            */

/* Order 0 jets: slots 0..2 carry number operands, 3 a number result, 4 the
 * condition a branch function passes to nz_jet_select. */
#define NSCALAR 5
/* Constant jets shaped like another operand, one per operand of the
 * three-operand functions (ifelse, clamp). */
#define NKONST 3

typedef struct jet_workspace {
  double *w;            /* scratch series for the kernels             */
  size_t wlen;
  nz_jet *scalar[NSCALAR];
  nz_jet *konst[NKONST];
  size_t konst_bytes[NKONST];
} jet_workspace;

static int workspace_gc(lua_State *L)
{
  jet_workspace *ws = lua_touserdata(L, 1);
  free(ws->w);
  for (int i = 0; i < NSCALAR; i++) nz_jet_free(ws->scalar[i]);
  for (int i = 0; i < NKONST; i++) free(ws->konst[i]);
  memset(ws, 0, sizeof *ws);
  return 0;
}

static jet_workspace *get_workspace(lua_State *L)
{
  return lua_touserdata(L, lua_upvalueindex(1));
}

double *nz_lua_jet_work(lua_State *L, double **w, size_t *wlen, int order)
{
  size_t need = nz_jet_work_len(order);
  if (*wlen < need) {
    double *p = realloc(*w, need * sizeof(double));
    if (!p) luaL_error(L, "not enough memory for a jet workspace of order %d", order);
    *w = p;
    *wlen = need;
  }
  return *w;
}

nz_jet *nz_lua_jet_room(lua_State *L, nz_jet **j, size_t *bytes, int order, int ntan)
{
  size_t need = nz_jet_bytes(order, ntan);
  if (*bytes < need) {
    void *p = realloc(*j, need);
    if (!p) luaL_error(L, "not enough memory for a jet of order %d", order);
    *j = p;
    *bytes = need;
  }
  (*j)->order = order;
  (*j)->ntan = ntan;
  return *j;
}

static double *work_for(lua_State *L, int order)
{
  jet_workspace *ws = get_workspace(L);
  return nz_lua_jet_work(L, &ws->w, &ws->wlen, order);
}

/* A constant jet of the given shape in slot s (valid until the next call). */
static nz_jet *constant_in(lua_State *L, int s, double v, int order, int ntan)
{
  jet_workspace *ws = get_workspace(L);
  nz_jet *c = nz_lua_jet_room(L, &ws->konst[s], &ws->konst_bytes[s], order, ntan);
  nz_jet_init(c, order, ntan);
  c->c[0] = v;
  return c;
}

static nz_jet *constant_like(lua_State *L, double v, int order, int ntan)
{
  return constant_in(L, 0, v, order, ntan);
}

/* ------------------------------------------------------------------ */
/* Checking and creating jets                                           */

nz_jet *nz_lua_tojet(lua_State *L, int idx)
{
  return luaL_testudata(L, idx, NZ_JET_METATABLE);
}

nz_jet *nz_lua_checkjet(lua_State *L, int idx)
{
  return luaL_checkudata(L, idx, NZ_JET_METATABLE);
}

nz_jet *nz_lua_newjet(lua_State *L, int order, int ntan)
{
  nz_jet *z = lua_newuserdatauv(L, nz_jet_bytes(order, ntan), 0);
  nz_jet_init(z, order, ntan);
  luaL_setmetatable(L, NZ_JET_METATABLE);
  return z;
}

/* A jet or a number at idx; a number becomes an order 0 jet in scalar slot s. */
static nz_jet *jet_or_scalar(lua_State *L, int idx, int s, const char *fname)
{
  nz_jet *j = nz_lua_tojet(L, idx);
  if (j) return j;
  int isnum;
  double v = lua_tonumberx(L, idx, &isnum);
  if (!isnum)
    luaL_error(L, "bad argument #%d to '%s' (number or jet expected, got %s)", idx, fname,
               luaL_typename(L, idx));
  jet_workspace *ws = get_workspace(L);
  ws->scalar[s]->c[0] = v;
  return ws->scalar[s];
}

/* ------------------------------------------------------------------ */
/* Errors: what went wrong, with the offending value, in Lua's style    */

/* The shortest of %.15g / %.17g that reads back as the same double; NaN and
 * infinities the same way on every C library. */
static const char *fmt_num(char *buf, size_t n, double v)
{
  if (isnan(v)) return "NaN";
  if (isinf(v)) return v > 0 ? "inf" : "-inf";
  snprintf(buf, n, "%.15g", v);
  if (strtod(buf, NULL) != v) snprintf(buf, n, "%.17g", v);
  return buf;
}

static int raise_status(lua_State *L, nz_status st, const char *fname, double v, double v2)
{
  char a[32], b[32];
  fmt_num(a, sizeof a, v);
  fmt_num(b, sizeof b, v2);
  switch (st) {
  case NZ_EDOM:
    if (!strcmp(fname, "log"))
      return luaL_error(L, "'log' of a non-positive value (got %s): log needs a positive argument", a);
    if (!strcmp(fname, "sqrt"))
      return luaL_error(L, "'sqrt' of a negative value (got %s)", a);
    if (!strcmp(fname, "asin") || !strcmp(fname, "acos"))
      return luaL_error(L, "'%s' of a value outside [-1, 1] (got %s)", fname, a);
    if (!strcmp(fname, "pow"))
      return luaL_error(L, "'pow' of a negative base (got %s) to a non-integer or jet exponent (%s)", a, b);
    return luaL_error(L, "'%s' of a value outside its domain (got %s)", fname, a);
  case NZ_ESING:
    if (!strcmp(fname, "atan2") || !strcmp(fname, "hypot"))
      return luaL_error(L, "'%s' at (0, 0) is not differentiable: a jet with derivatives "
                        "cannot pass through the origin", fname);
    return luaL_error(L, "'%s' is not differentiable at %s: a jet of order >= 1 or with "
                      "tangents would get infinite derivatives there", fname, a);
  case NZ_EZERODIV:
    if (!strcmp(fname, "pow"))
      return luaL_error(L, "'pow' of zero to a negative exponent (%s) divides by zero", b);
    return luaL_error(L, "'%s' by a series whose constant term is zero (divisor value %s)", fname, a);
  case NZ_ERANGE:
    return luaL_error(L, "'%s' overflows: a coefficient of the result is not finite "
                      "(argument value %s)", fname, a);
  case NZ_ENAN:
    return luaL_error(L, "'%s' of finite arguments gives NaN: terms of a coefficient "
                      "overflowed and cancelled (inf - inf) (argument value %s)", fname, a);
  case NZ_ENOMEM:
    return luaL_error(L, "'%s': not enough memory", fname);
  default:
    return 0;
  }
}

/* Where the first coefficient of x that is not finite sits, in words; NULL
 * when x is finite.  An order 0 jet without tangents is a plain number. */
static const char *describe_nonfinite(char *buf, size_t n, const nz_jet *x)
{
  size_t len = (size_t)(x->order + 1);
  for (int d = -1; d < x->ntan; d++) {
    const double *c = d < 0 ? x->c : nz_jet_tangent(x, d);
    for (size_t j = 0; j < len; j++) {
      if (isfinite(c[j])) continue;
      char v[32];
      const char *what = fmt_num(v, sizeof v, c[j]);
      if (x->order == 0 && x->ntan == 0) snprintf(buf, n, "got %s", what);
      else if (d < 0) snprintf(buf, n, "a jet whose coefficient %zu is %s", j, what);
      else snprintf(buf, n, "a jet whose tangent %d has %s in coefficient %zu", d + 1, what, j);
      return buf;
    }
  }
  return NULL;
}

/* An operation failed.  An operand that already carried NaN or inf is the
 * cause, so it is named first (the status would only describe its effect:
 * 'log' of NaN is not a "non-positive value"); otherwise the status says
 * what went wrong. */
static int raise_failure(lua_State *L, nz_status st, const char *fname, const nz_jet *const *ops,
                         int nops, double v, double v2)
{
  char where[96];
  for (int i = 0; i < nops; i++) {
    if (!describe_nonfinite(where, sizeof where, ops[i])) continue;
    return luaL_error(L, "bad argument #%d to '%s' (%s: %s came from an earlier computation, "
                      "such as 0/0, inf - inf or an overflow)", i + 1, fname, where,
                      strstr(where, "NaN") ? "the NaN" : "the infinity");
  }
  return raise_status(L, st, fname, v, v2);
}

int nz_lua_jet_raise(lua_State *L, nz_status st, const char *fname, const nz_jet *const *ops,
                     int nops, double v, double v2)
{
  return raise_failure(L, st, fname, ops, nops, v, v2);
}

/* Push the result: a number when every operand was a number. */
static void push_result(lua_State *L, nz_jet *z, int as_number)
{
  if (as_number) lua_pushnumber(L, z->c[0]);
}

/* ------------------------------------------------------------------ */
/* Other number types                                                   */

/* Another number type among the arguments takes the call: a table whose
 * metatable has a field named `name` (sin, atan2, __add, ...) is a number
 * type written in Lua (lua/nz/model/hyperdual.lua, the recorder's tracers); a full
 * userdata other than a jet with that field is one written in C (the state
 * direction's "nz.dualjet", src/lua_dualjet.c).  Tables come first: a nested
 * dual number whose parts are dualjets is the outer type.  Returns 1 and
 * leaves the result if it dispatched. */
int nz_lua_dispatch(lua_State *L, int nargs, const char *name, int userdata)
{
  for (int pass = 0; pass < 1 + (userdata != 0); pass++)
    for (int i = 1; i <= nargs; i++) {
      int t = lua_type(L, i);
      if (pass == 0 ? t != LUA_TTABLE : (t != LUA_TUSERDATA || nz_lua_tojet(L, i))) continue;
      if (luaL_getmetafield(L, i, name) == LUA_TNIL) continue;
      lua_insert(L, 1);
      lua_call(L, nargs, 1);
      return 1;
    }
  return 0;
}

/* Is argument i of another number type (a table, or a userdata that is not
 * a jet)? */
static int foreign(lua_State *L, int i)
{
  int t = lua_type(L, i);
  return t == LUA_TTABLE || (t == LUA_TUSERDATA && !nz_lua_tojet(L, i));
}

static int dispatch_to_table(lua_State *L, int nargs, const char *name)
{
  return nz_lua_dispatch(L, nargs, name, 1);
}

/* ------------------------------------------------------------------ */
/* Unary functions                                                      */

static int unary(lua_State *L, nz_jet_fn f)
{
  const char *fname = nz_jet_fn_names[f];
  lua_settop(L, 1);
  if (foreign(L, 1) && dispatch_to_table(L, 1, fname)) return 1;
  int as_number = lua_type(L, 1) == LUA_TNUMBER;
  nz_jet *x = jet_or_scalar(L, 1, 0, fname);
  nz_jet *z = as_number ? get_workspace(L)->scalar[2] : nz_lua_newjet(L, x->order, x->ntan);
  nz_status st = nz_jet_apply(z, f, x, work_for(L, x->order));
  if (st) return raise_failure(L, st, fname, (const nz_jet *const[]){ x }, 1, x->c[0], 0.0);
  push_result(L, z, as_number);
  return 1;
}

#define UNARY(name, FN) static int lj_##name(lua_State *L) { return unary(L, FN); }
NZ_LUA_JET_UNARY(UNARY)

/* ------------------------------------------------------------------ */
/* Binary operations: numbers on either side, jets of any shapes        */

const char *const nz_lua_binop_names[] = { "add", "sub", "mul", "division", "pow", "atan2", "hypot" };
const char *const nz_lua_binop_fields[] = { "__add", "__sub", "__mul", "__div", "__pow", "atan2",
                                            "hypot" };

static int binary(lua_State *L, nz_lua_binop op)
{
  const char *fname = nz_lua_binop_names[op];
  lua_settop(L, 2);
  if ((foreign(L, 1) || foreign(L, 2)) && dispatch_to_table(L, 2, nz_lua_binop_fields[op]))
    return 1;
  int na = lua_type(L, 1) == LUA_TNUMBER, nb = lua_type(L, 2) == LUA_TNUMBER;
  nz_jet *a = jet_or_scalar(L, 1, 0, fname);
  nz_jet *b = jet_or_scalar(L, 2, 1, fname);
  const nz_jet *const args[2] = { a, b };   /* as given, before any conversion */
  int order, ntan;
  nz_jet_result_shape(a, b, &order, &ntan);
  if (na && !nb) order = b->order;   /* a number is exact to every order */
  if (nb && !na) order = a->order;
  int as_number = na && nb;
  nz_jet *z = as_number ? get_workspace(L)->scalar[2] : nz_lua_newjet(L, order, ntan);
  double *w = work_for(L, order);
  double av = a->c[0], bv = b->c[0];
  nz_status st;

  /* A number operand becomes a constant of the other operand's shape, except
   * where a cheaper exact path exists (x + s, s x, x / s, x^s). */
  switch (op) {
  case NZ_OP_ADD:
    st = na ? nz_jet_offset(z, b, av) : nb ? nz_jet_offset(z, a, bv) : nz_jet_add(z, a, b);
    break;
  case NZ_OP_SUB:
    if (nb) st = nz_jet_offset(z, a, -bv);
    else if (na) {
      st = nz_jet_neg(z, b);
      if (!st) { z->c[0] += av; st = nz_jet_check_finite(z); }
    }
    else st = nz_jet_sub(z, a, b);
    break;
  case NZ_OP_MUL:
    st = na ? nz_jet_scale(z, b, av) : nb ? nz_jet_scale(z, a, bv) : nz_jet_mul(z, a, b, w);
    break;
  case NZ_OP_DIV:
    if (nb && !na) st = bv == 0.0 ? NZ_EZERODIV : nz_jet_scale(z, a, 1.0 / bv);
    else {
      if (na && !nb) a = constant_like(L, av, order, 0);
      st = nz_jet_div(z, a, b, w);
    }
    bv = b->c[0];
    av = bv;   /* report the divisor's value */
    break;
  case NZ_OP_POW:
    if (nb) st = nz_jet_pow(z, a, bv, w);
    else {
      if (na) a = constant_like(L, av, order, 0);
      st = nz_jet_pow_jet(z, a, b, w);
    }
    break;
  case NZ_OP_ATAN2:
  case NZ_OP_HYPOT:
    if (na && !nb) a = constant_like(L, av, order, 0);
    if (nb && !na) b = constant_like(L, bv, order, 0);
    st = op == NZ_OP_ATAN2 ? nz_jet_atan2(z, a, b, w) : nz_jet_hypot(z, a, b, w);
    break;
  default:
    st = NZ_EDOM;
  }
  if (st) return raise_failure(L, st, fname, args, 2, av, bv);
  push_result(L, z, as_number);
  return 1;
}

#define BINARY(name, OP) static int lj_##name(lua_State *L) { return binary(L, OP); }
NZ_LUA_JET_BINARY(BINARY)

static int lj_unm(lua_State *L)
{
  nz_jet *a = nz_lua_checkjet(L, 1);
  nz_jet_neg(nz_lua_newjet(L, a->order, a->ntan), a);
  return 1;
}

/* Comparisons compare values (the constant terms); a number type written
 * in Lua (a nested dual number) compares by its field v. */
static double value_of(lua_State *L, int idx)
{
  nz_jet *j = nz_lua_tojet(L, idx);
  if (j) return j->c[0];
  if (lua_type(L, idx) == LUA_TTABLE && luaL_getmetafield(L, idx, "__lt") != LUA_TNIL) {
    lua_pop(L, 1);
    lua_getfield(L, idx, "v");
    double v = value_of(L, lua_gettop(L));
    lua_pop(L, 1);
    return v;
  }
  return luaL_checknumber(L, idx);
}
/* A number type written in C (a dualjet) compares itself. */
static int compare_dispatch(lua_State *L, const char *field)
{
  lua_settop(L, 2);
  for (int i = 1; i <= 2; i++)
    if (lua_type(L, i) == LUA_TUSERDATA && !nz_lua_tojet(L, i)) return nz_lua_dispatch(L, 2, field, 1);
  return 0;
}
static int lj_eq(lua_State *L)
{
  if (compare_dispatch(L, "__eq")) return 1;
  lua_pushboolean(L, value_of(L, 1) == value_of(L, 2));
  return 1;
}
static int lj_lt(lua_State *L)
{
  if (compare_dispatch(L, "__lt")) return 1;
  lua_pushboolean(L, value_of(L, 1) < value_of(L, 2));
  return 1;
}
static int lj_le(lua_State *L)
{
  if (compare_dispatch(L, "__le")) return 1;
  lua_pushboolean(L, value_of(L, 1) <= value_of(L, 2));
  return 1;
}

/* ------------------------------------------------------------------ */
/* Branches that can be recorded: comparisons that return numbers and   */
/* selections of whole operands (nz_jet_compare, nz_jet_select).        */

/* Up to three operands, numbers or jets, and the result's shape (as in
 * binary(): the lower order of the jets, a number being exact to every
 * order, and the most tangents).  given[] keeps the operands as passed, for
 * the error messages. */
typedef struct branch_args {
  int n;
  nz_jet *x[3];
  const nz_jet *given[3];
  int order, ntan;
  int as_number;   /* every operand that shapes the result is a number */
} branch_args;

/* Read arguments first..last (at most 3, scalar slots 0..2) as operands;
 * those from `shape` on decide the result's shape, and a number among them
 * becomes a constant of that shape's order, so that the branch rule compares
 * series of the same length.  A Lua boolean is refused with the reason. */
static void read_branch_args(lua_State *L, int last, int shape, const char *fname, branch_args *o)
{
  int isnum[3], njets = 0;
  o->n = last;
  o->order = 0;
  o->ntan = 0;
  for (int i = 0; i < last; i++) {
    if (lua_type(L, i + 1) == LUA_TBOOLEAN)
      luaL_error(L, "bad argument #%d to '%s' (number or jet expected, got boolean): a Lua "
                 "comparison (x > 0) cannot be recorded; write the condition with nz.gt(x, 0), "
                 "nz.lt, nz.ge or nz.le", i + 1, fname);
    o->x[i] = jet_or_scalar(L, i + 1, i, fname);
    o->given[i] = o->x[i];
    isnum[i] = !nz_lua_tojet(L, i + 1);
  }
  for (int i = shape; i < last; i++) {
    if (o->x[i]->ntan > o->ntan) o->ntan = o->x[i]->ntan;
    if (isnum[i]) continue;
    if (njets == 0 || o->x[i]->order < o->order) o->order = o->x[i]->order;
    njets++;
  }
  o->as_number = njets == 0;
  if (o->as_number) return;
  for (int i = 0; i < last; i++)
    if (isnum[i]) o->x[i] = constant_in(L, i, o->x[i]->c[0], o->order, 0);
}

/* The result: a new jet of the shape, or the number slot. */
static nz_jet *branch_result(lua_State *L, const branch_args *o)
{
  return o->as_number ? get_workspace(L)->scalar[3] : nz_lua_newjet(L, o->order, o->ntan);
}

static int branch_failure(lua_State *L, nz_status st, const char *fname, const branch_args *o)
{
  return raise_failure(L, st, fname, o->given, o->n, o->given[0]->c[0],
                       o->n > 1 ? o->given[1]->c[0] : 0.0);
}

/* Another number type among the arguments gets the call. */
static int branch_dispatch(lua_State *L, int nargs, const char *fname)
{
  for (int i = 1; i <= nargs; i++)
    if (foreign(L, i)) return dispatch_to_table(L, nargs, fname);
  return 0;
}

/* a op b on arguments 1 and 2: 1 or 0, a number for numbers, else a
 * constant jet; with pick, the operand it selects (a where it holds). */
static int compare_args(lua_State *L, nz_cmp op, const char *fname, int pick)
{
  lua_settop(L, 2);
  if (branch_dispatch(L, 2, fname)) return 1;
  branch_args o;
  read_branch_args(L, 2, 0, fname, &o);
  nz_jet *z = branch_result(L, &o);
  nz_status st = nz_jet_compare(z, op, o.x[0], o.x[1]);
  if (!st && pick) st = nz_jet_select(z, z, o.x[0], o.x[1]);   /* z may alias the condition */
  if (st) return branch_failure(L, st, fname, &o);
  push_result(L, z, o.as_number);
  return 1;
}

static int lj_lt_fn(lua_State *L) { return compare_args(L, NZ_CMP_LT, "lt", 0); }
static int lj_le_fn(lua_State *L) { return compare_args(L, NZ_CMP_LE, "le", 0); }
static int lj_gt_fn(lua_State *L) { return compare_args(L, NZ_CMP_GT, "gt", 0); }
static int lj_ge_fn(lua_State *L) { return compare_args(L, NZ_CMP_GE, "ge", 0); }

/* nz.ifelse(c, a, b): a where c's value is nonzero, else b.  The result has
 * the shape of a and b (c only chooses); a number when both are numbers. */
static int lj_ifelse(lua_State *L)
{
  lua_settop(L, 3);
  if (branch_dispatch(L, 3, "ifelse")) return 1;
  branch_args o;
  read_branch_args(L, 3, 1, "ifelse", &o);
  nz_jet *z = branch_result(L, &o);
  nz_status st = nz_jet_select(z, o.x[0], o.x[1], o.x[2]);
  if (st) return branch_failure(L, st, "ifelse", &o);
  push_result(L, z, o.as_number);
  return 1;
}

/* max(a, b) = select(ge(a, b), a, b), min(a, b) = select(le(a, b), a, b):
 * at a tie in every known coefficient the first operand is returned. */
static int lj_max(lua_State *L) { return compare_args(L, NZ_CMP_GE, "max", 1); }
static int lj_min(lua_State *L) { return compare_args(L, NZ_CMP_LE, "min", 1); }

/* nz.clamp(x, lo, hi) = min(max(x, lo), hi), lo <= hi: lo where x < lo, hi
 * where x > hi, else x (x itself at a tie with a bound). */
static int lj_clamp(lua_State *L)
{
  lua_settop(L, 3);
  if (branch_dispatch(L, 3, "clamp")) return 1;
  branch_args o;
  read_branch_args(L, 3, 0, "clamp", &o);
  nz_jet *z = branch_result(L, &o), *c = get_workspace(L)->scalar[4];
  nz_jet *x = o.x[0], *lo = o.x[1], *hi = o.x[2];
  nz_status st = nz_jet_compare(z, NZ_CMP_GT, lo, hi);
  if (st) return branch_failure(L, st, "clamp", &o);
  if (z->c[0] != 0.0) {
    char a[32], b[32];
    return luaL_error(L, "bad argument #2 to 'clamp' (the lower bound %s is above the upper "
                      "bound %s, compared as series: clamp(x, lo, hi) needs lo <= hi)",
                      fmt_num(a, sizeof a, lo->c[0]), fmt_num(b, sizeof b, hi->c[0]));
  }
  st = nz_jet_compare(z, NZ_CMP_LT, x, lo);
  double below = z->c[0];
  if (!st) st = nz_jet_compare(z, NZ_CMP_GT, x, hi);
  double above = z->c[0];
  c->c[0] = below;
  if (!st) st = nz_jet_select(z, c, lo, x);
  c->c[0] = above;
  if (!st) st = nz_jet_select(z, c, hi, z);   /* z may be the operand it keeps */
  if (st) return branch_failure(L, st, "clamp", &o);
  push_result(L, z, o.as_number);
  return 1;
}

/* ------------------------------------------------------------------ */
/* Construction                                                         */

/* Argument idx as a whole number from lo to hi (what names it; lo_is, when
 * not NULL, says where lo comes from), else an error that says which
 * numbers it takes and what it got (2.5, nan, 1e+300 too). */
static int check_count(lua_State *L, int idx, int lo, int hi, const char *what, const char *lo_is)
{
  double v = luaL_checknumber(L, idx);
  if (!(v >= lo && v <= hi && v == floor(v))) {
    char a[32];
    return (int)luaL_error(L, "bad argument #%d to 'jet' (%s must be a whole number from %d%s%s%s to %d, got %s)",
                           idx, what, lo, lo_is ? " (" : "", lo_is ? lo_is : "", lo_is ? ")" : "", hi,
                           fmt_num(a, sizeof a, v));
  }
  return (int)v;
}

/* A jet starts finite: NaN or inf in a value or coefficient would only
 * surface later, far from where it came in (every operation keeps jets
 * finite, see nz_jet_check_finite). */
static double check_finite_arg(lua_State *L, int idx, const char *fname)
{
  double v = luaL_checknumber(L, idx);
  if (!isfinite(v)) {
    char a[32];
    luaL_error(L, "bad argument #%d to '%s' (finite number expected, got %s)", idx, fname,
               fmt_num(a, sizeof a, v));
  }
  return v;
}

/* Read the numbers of the list at idx into dst[0..n-1], zero beyond its end. */
static void read_coefficients(lua_State *L, int idx, double *dst, int n, const char *what)
{
  for (int j = 0; j < n; j++) {
    int t = lua_geti(L, idx, j + 1);
    if (t == LUA_TNIL) dst[j] = 0.0;
    else if (t == LUA_TNUMBER) dst[j] = lua_tonumber(L, -1);
    else luaL_error(L, "bad argument to 'jet' (%s: entry %d is a %s, number expected)", what,
                    j + 1, lua_typename(L, t));
    if (!isfinite(dst[j])) {
      char a[32];
      luaL_error(L, "bad argument to 'jet' (%s: entry %d is %s, finite number expected)", what,
                 j + 1, fmt_num(a, sizeof a, dst[j]));
    }
    lua_pop(L, 1);
  }
}

/* nz.jet{c0, c1, ..., order = K, tangents = {{...}, ...}} */
static int jet_from_table(lua_State *L)
{
  int ncoef = (int)luaL_len(L, 1);
  int order = ncoef - 1;
  if (lua_getfield(L, 1, "order") != LUA_TNIL) {
    double v = lua_tonumber(L, -1);
    if (!lua_isnumber(L, -1) || !(v >= 0 && v <= NZ_JET_MAX_ORDER && v == floor(v))) {
      char a[32];
      return luaL_error(L, "bad argument #1 to 'jet' (field 'order' must be a whole number from 0 to %d, got %s)",
                        NZ_JET_MAX_ORDER, lua_isnumber(L, -1) ? fmt_num(a, sizeof a, v) : luaL_typename(L, -1));
    }
    order = (int)v;
  }
  lua_pop(L, 1);
  if (order < 0 || order > NZ_JET_MAX_ORDER)
    return luaL_error(L, "bad argument #1 to 'jet' (a list of 1 to %d coefficients expected, "
                      "got order %d)", NZ_JET_MAX_ORDER + 1, order);
  if (ncoef > order + 1)
    return luaL_error(L, "bad argument #1 to 'jet' (%d coefficients given for order %d)", ncoef, order);
  int ntan = 0;
  int has_tan = lua_getfield(L, 1, "tangents") != LUA_TNIL;
  if (has_tan) {
    luaL_argexpected(L, lua_istable(L, -1), 1, "table of tangent series in field 'tangents'");
    ntan = (int)luaL_len(L, -1);
    if (ntan > NZ_JET_MAX_TANGENTS)
      return luaL_error(L, "bad argument #1 to 'jet' (at most %d tangents)", NZ_JET_MAX_TANGENTS);
  }
  int tanidx = lua_gettop(L);
  nz_jet *z = nz_lua_newjet(L, order, ntan);
  read_coefficients(L, 1, z->c, ncoef, "coefficients");
  for (int d = 0; d < ntan; d++) {
    lua_geti(L, tanidx, d + 1);
    if (!lua_istable(L, -1))
      return luaL_error(L, "bad argument #1 to 'jet' (tangent %d must be a list of coefficients)", d + 1);
    read_coefficients(L, lua_gettop(L), nz_jet_tangent(z, d), order + 1, "tangent series");
    lua_pop(L, 1);
  }
  return 1;
}

/* nz.jet(t0, order [, d, D]): the variable t0 + (t - t0); with d, tangent
 * direction d of D is seeded (the derivative with respect to t0). */
static int lj_jet(lua_State *L)
{
  if (lua_istable(L, 1)) return jet_from_table(L);
  double t0 = check_finite_arg(L, 1, "jet");
  int order = lua_isnoneornil(L, 2) ? 1 : check_count(L, 2, 0, NZ_JET_MAX_ORDER, "the order", NULL);
  int seed = -1, ntan = 0;
  if (!lua_isnoneornil(L, 3)) {
    seed = check_count(L, 3, 1, NZ_JET_MAX_TANGENTS, "the tangent direction", NULL) - 1;
    ntan = lua_isnoneornil(L, 4) ? seed + 1
                                 : check_count(L, 4, seed + 1, NZ_JET_MAX_TANGENTS, "the tangent count",
                                               "the tangent direction: direction d needs d tangents");
  }
  nz_jet_set_variable(nz_lua_newjet(L, order, ntan), t0, seed);
  return 1;
}

/* nz.dual(v, d, D): the dual number v + eps_d (a jet of order 0). */
static int lj_dual(lua_State *L)
{
  double v = check_finite_arg(L, 1, "dual");
  int seed = check_count(L, 2, 1, NZ_JET_MAX_TANGENTS, "the tangent direction", NULL) - 1;
  int ntan = lua_isnoneornil(L, 3) ? seed + 1
                                   : check_count(L, 3, seed + 1, NZ_JET_MAX_TANGENTS, "the tangent count",
                                                 "the tangent direction: direction d needs d tangents");
  nz_jet_set_variable(nz_lua_newjet(L, 0, ntan), v, seed);
  return 1;
}

/* A jet, or a number type that answers as one (the recorder's tracers
 * stand for the jets the Lua evaluator passes: lua/nz/model/record.lua). */
static int lj_isjet(lua_State *L)
{
  lua_settop(L, 1);
  if (foreign(L, 1) && dispatch_to_table(L, 1, "isjet")) return 1;
  lua_pushboolean(L, nz_lua_tojet(L, 1) != NULL);
  return 1;
}

/* ------------------------------------------------------------------ */
/* Methods                                                              */

static int check_index(lua_State *L, int idx, int hi, const char *fname, const char *what)
{
  lua_Integer j = luaL_checkinteger(L, idx);
  if (j < 0 || j > hi)
    return (int)luaL_error(L, "bad argument #%d to '%s' (%s between 0 and %d expected, got %I)",
                           idx - 1, fname, what, hi, (lua_Integer)j);
  return (int)j;
}

static int lj_coef(lua_State *L)
{
  nz_jet *x = nz_lua_checkjet(L, 1);
  lua_pushnumber(L, x->c[check_index(L, 2, x->order, "coef", "coefficient index")]);
  return 1;
}

/* x:deriv(j) = j! c_j.  Normalized coefficients fall below the smallest
 * normal double (DBL_MIN) near j = 171 for an O(1) function, and to 0 a few
 * orders later, where j! overflows: j! c_j then has lost its digits, or is 0
 * for a derivative that is not.  A subnormal c_j is refused, and so is a zero
 * c_j when an underflowed coefficient (below DBL_TRUE_MIN) could hide a
 * derivative larger than DBL_EPSILON; never a wrong derivative. */
static int lj_deriv(lua_State *L)
{
  nz_jet *x = nz_lua_checkjet(L, 1);
  int j = check_index(L, 2, x->order, "deriv", "derivative order");
  double c = x->c[j], d = c, hidden = DBL_TRUE_MIN;
  for (int i = 2; i <= j; i++) { d *= i; hidden *= i; }
  char a[32];
  if (c != 0.0 && fabs(c) < DBL_MIN)
    return luaL_error(L, "'deriv': coefficient %d (%s) has underflowed below the smallest normal "
                      "double, so %d! times it has lost its digits; coef(%d) is the coefficient "
                      "itself, or scale time: with h > 1, nz.jet{t0, h, order = K} has the "
                      "coefficients f^(j) h^j / j!", j, fmt_num(a, sizeof a, c), j, j);
  if (c == 0.0 && hidden > DBL_EPSILON) {
    char bound[16];
    snprintf(bound, sizeof bound, "%.2g", hidden);
    return luaL_error(L, "'deriv': coefficient %d is 0, and %d! times a coefficient that "
                      "underflowed to 0 can be %s: derivative %d cannot be told from 0; "
                      "scale time instead: with h > 1, nz.jet{t0, h, order = K} has the "
                      "coefficients f^(j) h^j / j!", j, j, bound, j);
  }
  if (!isfinite(d))
    return luaL_error(L, "'deriv': %d! times coefficient %d (%s) overflows a double; "
                      "use coef(%d) instead", j, j, fmt_num(a, sizeof a, c), j);
  lua_pushnumber(L, d);
  return 1;
}

static int lj_order(lua_State *L) { lua_pushinteger(L, nz_lua_checkjet(L, 1)->order); return 1; }
static int lj_ntangents(lua_State *L) { lua_pushinteger(L, nz_lua_checkjet(L, 1)->ntan); return 1; }
static int lj_value(lua_State *L) { lua_pushnumber(L, nz_lua_checkjet(L, 1)->c[0]); return 1; }

/* x:tangent(d): the series of direction d as a jet without tangents. */
static int lj_tangent(lua_State *L)
{
  nz_jet *x = nz_lua_checkjet(L, 1);
  lua_Integer d = luaL_checkinteger(L, 2);
  if (d < 1 || d > x->ntan)
    return luaL_error(L, "bad argument #1 to 'tangent' (direction between 1 and %d expected, got %I)",
                      x->ntan, (lua_Integer)d);
  nz_jet *z = nz_lua_newjet(L, x->order, 0);
  memcpy(z->c, nz_jet_tangent(x, (int)d - 1), (size_t)(x->order + 1) * sizeof(double));
  return 1;
}

/* x:derivative(): the series of dx/dt, one order lower:  c'_j = (j+1) c_{j+1},
 * the same for every tangent series. */
static int lj_derivative(lua_State *L)
{
  nz_jet *x = nz_lua_checkjet(L, 1);
  if (x->order < 1)
    return luaL_error(L, "'derivative' of a jet of order 0: its derivative is unknown");
  nz_jet *z = nz_lua_newjet(L, x->order - 1, x->ntan);
  for (int d = -1; d < x->ntan; d++) {
    const double *src = d < 0 ? x->c : nz_jet_tangent(x, d);
    double *dst = d < 0 ? z->c : nz_jet_tangent(z, d);
    for (int j = 0; j < x->order; j++) dst[j] = (j + 1) * src[j + 1];
  }
  nz_status st = nz_jet_check_finite(z);
  if (st) return raise_failure(L, st, "derivative", (const nz_jet *const[]){ x }, 1, x->c[0], 0.0);
  return 1;
}

static int lj_coefs(lua_State *L)
{
  nz_jet *x = nz_lua_checkjet(L, 1);
  lua_createtable(L, x->order + 1, 0);
  for (int j = 0; j <= x->order; j++) {
    lua_pushnumber(L, x->c[j]);
    lua_rawseti(L, -2, j + 1);
  }
  return 1;
}

/* A coefficient in the shortest decimal that reads back exactly (%.15g,
 * %.16g or %.17g), as the session prints a number (lua/nz/session/repl.lua):
 * 1/6 is 0.16666666666666666, 0.1 stays 0.1. */
static void add_number(luaL_Buffer *b, double v)
{
  char num[40];
  for (int digits = 15; digits <= 17; digits++) {
    snprintf(num, sizeof num, "%.*g", digits, v);
    if (strtod(num, NULL) == v) break;
  }
  luaL_addstring(b, num);
}

static void add_series(luaL_Buffer *b, const double *c, int K)
{
  int shown = K < 7 ? K : 7;
  for (int j = 0; j <= shown; j++) {
    if (j) luaL_addstring(b, ", ");
    add_number(b, c[j]);
  }
  if (shown < K) luaL_addstring(b, ", ...");
}

static int lj_tostring(lua_State *L)
{
  nz_jet *x = nz_lua_checkjet(L, 1);
  luaL_Buffer b;
  char head[80];
  luaL_buffinit(L, &b);
  luaL_addstring(&b, "jet{");
  add_series(&b, x->c, x->order);
  snprintf(head, sizeof head, "; order %d", x->order);
  luaL_addstring(&b, head);
  for (int d = 0; d < x->ntan && d < 4; d++) {
    snprintf(head, sizeof head, "; d%d: ", d + 1);
    luaL_addstring(&b, head);
    add_series(&b, nz_jet_tangent(x, d), x->order);
  }
  if (x->ntan > 4) {
    snprintf(head, sizeof head, "; %d tangents", x->ntan);
    luaL_addstring(&b, head);
  }
  luaL_addstring(&b, "}");
  luaL_pushresult(&b);
  return 1;
}

/* ------------------------------------------------------------------ */
/* Registration                                                         */

static const luaL_Reg jet_methods[] = {
  { "coef", lj_coef }, { "deriv", lj_deriv }, { "order", lj_order },
  { "value", lj_value }, { "ntangents", lj_ntangents }, { "tangent", lj_tangent },
  { "coefs", lj_coefs }, { "derivative", lj_derivative }, { NULL, NULL }
};

static const luaL_Reg jet_metamethods[] = {
  { "__add", lj_add }, { "__sub", lj_sub }, { "__mul", lj_mul }, { "__div", lj_div },
  { "__pow", lj_pow }, { "__unm", lj_unm }, { "__eq", lj_eq }, { "__lt", lj_lt },
  { "__le", lj_le }, { "__tostring", lj_tostring }, { NULL, NULL }
};

static const luaL_Reg jet_functions[] = {
  { "jet", lj_jet }, { "dual", lj_dual }, { "isjet", lj_isjet },
  { "exp", lj_exp }, { "log", lj_log }, { "sqrt", lj_sqrt }, { "sin", lj_sin },
  { "cos", lj_cos }, { "tan", lj_tan }, { "asin", lj_asin }, { "acos", lj_acos },
  { "atan", lj_atan }, { "atan2", lj_atan2 }, { "sinh", lj_sinh }, { "cosh", lj_cosh },
  { "tanh", lj_tanh }, { "abs", lj_abs }, { "hypot", lj_hypot }, { "pow", lj_pow },
  { "sign", lj_sign }, { "ifelse", lj_ifelse }, { "lt", lj_lt_fn }, { "le", lj_le_fn },
  { "gt", lj_gt_fn }, { "ge", lj_ge_fn }, { "max", lj_max }, { "min", lj_min },
  { "clamp", lj_clamp }, { NULL, NULL }
};

void *nz_lua_push_workspace(lua_State *L, size_t size, lua_CFunction gc)
{
  void *ws = lua_newuserdatauv(L, size, 0);
  memset(ws, 0, size);
  lua_createtable(L, 0, 1);
  lua_pushcfunction(L, gc);
  lua_setfield(L, -2, "__gc");
  lua_setmetatable(L, -2);
  return ws;
}

static void push_workspace(lua_State *L)
{
  jet_workspace *ws = nz_lua_push_workspace(L, sizeof *ws, workspace_gc);
  for (int i = 0; i < NSCALAR; i++)
    if (!(ws->scalar[i] = nz_jet_alloc(0, 0))) luaL_error(L, "not enough memory");
}

void nz_lua_open_jet(lua_State *L)
{
  push_workspace(L);                          /* module, ws */
  if (luaL_newmetatable(L, NZ_JET_METATABLE)) {
    lua_pushvalue(L, -2);
    luaL_setfuncs(L, jet_metamethods, 1);
    luaL_newlib(L, jet_methods);
    lua_setfield(L, -2, "__index");
  }
  lua_pop(L, 1);                              /* module, ws */
  luaL_setfuncs(L, jet_functions, 1);         /* module */
}
