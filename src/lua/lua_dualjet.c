/* lua_dualjet.c - numbers v + eta d along a state direction (see
 * lua_dualjet.h), for the Lua evaluator of the exact Jacobian.
 *
 * Why in C: the direction used to be a Lua table type (lua/nz/model/hyperdual.lua)
 * whose every operation went C -> Lua -> C and allocated three objects.  A
 * dualjet is one userdata holding both jets, and each operation is one call.
 *
 * The eta-parts are the jets' rules (src/jets/jet_eta.c, nz_jet_eta), which
 * the graph evaluator (src/graph/graph_jets.c) calls too, so that the two
 * evaluators of a system agree along a direction as they agree on values.
 *   (v + eta d) op (w + eta e): add, sub linear; mul v w + eta (d w + v e);
 *   div z = v / w, eta (d - z e) / w; f(v + eta d) = f(v) + eta f'(v) d;
 *   comparisons and sign look at v alone (a step: no eta-part); a selection
 *   takes v and d from the same operand.
 * Shapes: the value part has the shape a jet operation gives (the lowest
 * order of the operands that are not numbers, the most tangents); the
 * eta-part has that order lowered to the operands' eta-parts' and the most
 * tangents of all (a number or a plain jet has eta-part zero).
 *
 * Another number type written in Lua among the operands (a nested dual
 * number of nz/model/hyperdual.lua whose parts are dualjets) is the outer type:
 * it takes the call. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "jets/jet_eta.h"
#include "lua/lua_dualjet.h"
#include "lua/lua_jet.h"

typedef struct dualjet {
  nz_jet *v;   /* value part, stored right after this header */
  nz_jet *d;   /* eta-part, stored after v                    */
} dualjet;

static int imin(int a, int b) { return a < b ? a : b; }
static int imax(int a, int b) { return a > b ? a : b; }

/* ------------------------------------------------------------------ */
/* Workspace (upvalue 1; upvalue 2 is the core module)                   */

#define NSCALAR 2   /* order 0 jets carrying number operands             */
#define NKONST 2    /* a number operand as a constant of the result's order */
#define NTEMP 4     /* temporaries of the eta-part's shape              */

typedef struct slot {
  nz_jet *j;
  size_t bytes;
} slot;

typedef struct dual_ws {
  double *w;
  size_t wlen;
  slot scalar[NSCALAR], konst[NKONST], tmp[NTEMP];
} dual_ws;

static int workspace_gc(lua_State *L)
{
  dual_ws *ws = lua_touserdata(L, 1);
  free(ws->w);
  for (int i = 0; i < NSCALAR; i++) free(ws->scalar[i].j);
  for (int i = 0; i < NKONST; i++) free(ws->konst[i].j);
  for (int i = 0; i < NTEMP; i++) free(ws->tmp[i].j);
  memset(ws, 0, sizeof *ws);
  return 0;
}

static dual_ws *get_ws(lua_State *L) { return lua_touserdata(L, lua_upvalueindex(1)); }

static double *work_for(lua_State *L, int order)
{
  dual_ws *ws = get_ws(L);
  return nz_lua_jet_work(L, &ws->w, &ws->wlen, order);
}

/* The jet of slot s shaped (order, ntan); its coefficients are not set. */
static nz_jet *shaped(lua_State *L, slot *s, int order, int ntan)
{
  return nz_lua_jet_room(L, &s->j, &s->bytes, order, ntan);
}

/* The temporaries of nz_jet_eta, with room for the shape of `like`. */
static nz_jet *const *temps(lua_State *L, const nz_jet *like, nz_jet *T[NTEMP])
{
  for (int i = 0; i < NTEMP; i++) T[i] = shaped(L, &get_ws(L)->tmp[i], like->order, like->ntan);
  return T;
}

/* The number v as a constant series of that order (exact to every order). */
static nz_jet *constant(lua_State *L, int s, double v, int order)
{
  nz_jet *c = shaped(L, &get_ws(L)->konst[s], order, 0);
  nz_jet_set_constant(c, v);
  return c;
}

/* ------------------------------------------------------------------ */
/* Making and reading dualjets                                           */

static dualjet *new_dual(lua_State *L, int vo, int vn, int eo, int en)
{
  size_t hv = nz_jet_bytes(vo, vn);   /* a multiple of sizeof(double) */
  dualjet *x = lua_newuserdatauv(L, sizeof *x + hv + nz_jet_bytes(eo, en), 0);
  x->v = (nz_jet *)(void *)(x + 1);
  x->d = (nz_jet *)(void *)((char *)(x + 1) + hv);
  nz_jet_init(x->v, vo, vn);
  nz_jet_init(x->d, eo, en);
  luaL_setmetatable(L, NZ_DUALJET_METATABLE);
  return x;
}

static dualjet *todual(lua_State *L, int idx) { return luaL_testudata(L, idx, NZ_DUALJET_METATABLE); }

int nz_lua_todualjet(lua_State *L, int idx, const nz_jet **v, const nz_jet **d)
{
  dualjet *x = todual(L, idx);
  if (!x) return 0;
  *v = x->v;
  *d = x->d;
  return 1;
}

void nz_lua_push_dualjet(lua_State *L, const nz_jet *v, const nz_jet *d)
{
  dualjet *x = new_dual(L, v->order, v->ntan, d ? d->order : v->order, d ? d->ntan : v->ntan);
  nz_jet_copy(x->v, v);
  nz_jet_copy_fit(x->d, d);
}

/* An operand: a dualjet's parts, a jet (eta-part zero) or a number (an
 * order 0 jet in a scalar slot). */
typedef struct operand {
  const nz_jet *v, *d;   /* d NULL: zero */
  int num;
} operand;

static void read_operand(lua_State *L, int idx, int s, const char *fname, operand *o)
{
  dualjet *x = todual(L, idx);
  o->num = 0;
  if (x) {
    o->v = x->v;
    o->d = x->d;
    return;
  }
  o->d = NULL;
  if ((o->v = nz_lua_tojet(L, idx))) return;
  int isnum;
  double v = lua_tonumberx(L, idx, &isnum);
  if (!isnum)
    luaL_error(L, "bad argument #%d to '%s' (number, jet or dualjet expected, got %s)", idx, fname,
               luaL_typename(L, idx));
  nz_jet *c = shaped(L, &get_ws(L)->scalar[s], 0, 0);
  c->c[0] = v;
  o->v = c;
  o->num = 1;
}

/* ------------------------------------------------------------------ */
/* Unary functions: f(v + eta d) = f(v) + eta f'(v) d                   */

static int raise1(lua_State *L, nz_status st, const char *fname, const nz_jet *a)
{
  return nz_lua_jet_raise(L, st, fname, (const nz_jet *const[]){ a }, 1, a->c[0], 0.0);
}

static int unary(lua_State *L, nz_jet_fn f)
{
  const char *fname = nz_jet_fn_names[f];
  lua_settop(L, 1);
  if (lua_type(L, 1) == LUA_TTABLE && nz_lua_dispatch(L, 1, fname, 0)) return 1;
  dualjet *x = luaL_checkudata(L, 1, NZ_DUALJET_METATABLE);
  const nz_jet *A = x->v, *dA = x->d;
  double *w = work_for(L, A->order);
  nz_status st;
  if (f == NZ_FN_SIGN) {   /* a step: a plain jet, as the jets give it */
    st = nz_jet_apply(nz_lua_newjet(L, A->order, A->ntan), f, A, w);
    return st ? raise1(L, st, fname, A) : 1;
  }
  dualjet *z = new_dual(L, A->order, A->ntan, imin(A->order, dA->order), imax(A->ntan, dA->ntan));
  nz_jet *T[NTEMP];
  nz_eta_args e = { NZ_ETA_FN, f, 0.0, A, A, z->v, dA, NULL, 0, 0 };
  if ((st = nz_jet_apply(z->v, f, A, w)) || (st = nz_jet_eta(z->d, &e, temps(L, z->d, T), w)))
    return raise1(L, st, fname, A);
  return 1;
}

#define UNARY(name, FN) static int dj_##name(lua_State *L) { return unary(L, FN); }
NZ_LUA_JET_UNARY(UNARY)

static int dj_unm(lua_State *L)
{
  dualjet *x = luaL_checkudata(L, 1, NZ_DUALJET_METATABLE);
  dualjet *z = new_dual(L, x->v->order, x->v->ntan, x->d->order, x->d->ntan);
  (void)nz_jet_affine(z->v, x->v, -1.0, 0.0);   /* finite operands stay finite */
  (void)nz_jet_affine(z->d, x->d, -1.0, 0.0);
  return 1;
}

/* ------------------------------------------------------------------ */
/* Binary operations: numbers, jets and dualjets in any order            */

/* The value part, as the jets compute it (lua_jet.c's binary): a number
 * operand by a cheaper exact path where there is one, else as a constant
 * of the result's order.  A and B are the operands as used (the constants
 * the eta-part needs too). */
static nz_status value_binary(nz_lua_binop op, nz_jet *z, const nz_jet *A, const nz_jet *B,
                              int na, int nb, double *w)
{
  double av = A->c[0], bv = B->c[0];
  nz_status st;
  switch (op) {
  case NZ_OP_ADD: return na ? nz_jet_offset(z, B, av) : nb ? nz_jet_offset(z, A, bv) : nz_jet_add(z, A, B);
  case NZ_OP_SUB:
    if (nb) return nz_jet_offset(z, A, -bv);
    if (!na) return nz_jet_sub(z, A, B);
    if ((st = nz_jet_neg(z, B))) return st;
    z->c[0] += av;
    return nz_jet_check_finite(z);
  case NZ_OP_MUL: return na ? nz_jet_scale(z, B, av) : nb ? nz_jet_scale(z, A, bv) : nz_jet_mul(z, A, B, w);
  case NZ_OP_DIV:
    if (nb && !na) return bv == 0.0 ? NZ_EZERODIV : nz_jet_scale(z, A, 1.0 / bv);
    return nz_jet_div(z, A, B, w);
  case NZ_OP_POW: return nb ? nz_jet_pow(z, A, bv, w) : nz_jet_pow_jet(z, A, B, w);
  case NZ_OP_ATAN2: return nz_jet_atan2(z, A, B, w);
  case NZ_OP_HYPOT: return nz_jet_hypot(z, A, B, w);
  default: return NZ_EDOM;
  }
}

/* The eta rule of each operation; a number exponent makes pow a powc. */
static const nz_eta_op binop_eta[] = { NZ_ETA_ADD, NZ_ETA_SUB, NZ_ETA_MUL, NZ_ETA_DIV,
                                       NZ_ETA_POW, NZ_ETA_ATAN2, NZ_ETA_HYPOT };

/* The eta-part into Ez by the jets' rules, a number being a constant. */
static nz_status eta_binary(lua_State *L, nz_lua_binop op, nz_jet *Ez, const nz_jet *A,
                            const nz_jet *B, const nz_jet *Z, const nz_jet *dA, const nz_jet *dB,
                            int na, int nb, double *w)
{
  nz_jet *T[NTEMP];
  nz_eta_args e = { binop_eta[op], NZ_FN_EXP, B->c[0], A, B, Z, dA, dB, na, nb };
  if (op == NZ_OP_POW && nb) e.op = NZ_ETA_POWC;
  return nz_jet_eta(Ez, &e, temps(L, Ez, T), w);
}

static int binary(lua_State *L, nz_lua_binop op)
{
  const char *fname = nz_lua_binop_names[op];
  lua_settop(L, 2);
  if ((lua_type(L, 1) == LUA_TTABLE || lua_type(L, 2) == LUA_TTABLE) &&
      nz_lua_dispatch(L, 2, nz_lua_binop_fields[op], 0))
    return 1;
  operand a, b;
  read_operand(L, 1, 0, fname, &a);
  read_operand(L, 2, 1, fname, &b);
  const nz_jet *const given[2] = { a.v, b.v };   /* for the messages */
  /* Shapes: a number is exact to every order; a missing eta-part is zero. */
  int order = a.num && b.num ? 0 : a.num ? b.v->order : b.num ? a.v->order : imin(a.v->order, b.v->order);
  int ntan = imax(a.v->ntan, b.v->ntan), eo = order, en = ntan;
  if (a.d) { eo = imin(eo, a.d->order); en = imax(en, a.d->ntan); }
  if (b.d) { eo = imin(eo, b.d->order); en = imax(en, b.d->ntan); }
  dualjet *z = new_dual(L, order, ntan, eo, en);
  double *w = work_for(L, order);
  const nz_jet *A = a.v, *B = b.v;
  double av = A->c[0], bv = B->c[0];
  if (a.num && !b.num &&
      (op == NZ_OP_DIV || op == NZ_OP_POW || op == NZ_OP_ATAN2 || op == NZ_OP_HYPOT))
    A = constant(L, 0, av, order);
  if (b.num && !a.num && (op == NZ_OP_ATAN2 || op == NZ_OP_HYPOT)) B = constant(L, 1, bv, order);
  if (op == NZ_OP_DIV) av = bv;   /* the jets report the divisor's value */
  nz_status st = value_binary(op, z->v, A, B, a.num, b.num, w);
  if (!st) st = eta_binary(L, op, z->d, A, B, z->v, a.d, b.d, a.num, b.num, w);
  if (st) return nz_lua_jet_raise(L, st, fname, given, 2, av, bv);
  return 1;
}

#define BINARY(name, OP) static int dj_##name(lua_State *L) { return binary(L, OP); }
NZ_LUA_JET_BINARY(BINARY)

/* ------------------------------------------------------------------ */
/* Comparisons and branches: on the value parts                         */

/* The value of a number, jet or dualjet (its v's constant term). */
static double value_at(lua_State *L, int idx)
{
  dualjet *x = todual(L, idx);
  if (x) return x->v->c[0];
  nz_jet *j = nz_lua_tojet(L, idx);
  if (j) return j->c[0];
  return luaL_checknumber(L, idx);
}

typedef enum { CMP_EQ, CMP_LT, CMP_LE } cmpop;
static const char *const cmp_fields[] = { "__eq", "__lt", "__le" };

static int compare(lua_State *L, cmpop op)
{
  lua_settop(L, 2);
  if ((lua_type(L, 1) == LUA_TTABLE || lua_type(L, 2) == LUA_TTABLE) &&
      nz_lua_dispatch(L, 2, cmp_fields[op], 0))
    return 1;
  double a = value_at(L, 1), b = value_at(L, 2);
  lua_pushboolean(L, op == CMP_EQ ? a == b : op == CMP_LT ? a < b : a <= b);
  return 1;
}

static int dj_eq(lua_State *L) { return compare(L, CMP_EQ); }
static int dj_lt(lua_State *L) { return compare(L, CMP_LT); }
static int dj_le(lua_State *L) { return compare(L, CMP_LE); }

/* Push argument idx with a dualjet replaced by its value part (a new jet). */
static void push_value(lua_State *L, int idx)
{
  dualjet *x = todual(L, idx);
  if (!x) {
    lua_pushvalue(L, idx);
    return;
  }
  nz_jet_copy(nz_lua_newjet(L, x->v->order, x->v->ntan), x->v);
}

/* Push the jets' function `name` (core module) applied to the value parts
 * of arguments idx[0..n-1]: the jets' branch rule and their messages. */
static void call_jets(lua_State *L, const char *name, int n, const int *idx)
{
  lua_getfield(L, lua_upvalueindex(2), name);
  for (int i = 0; i < n; i++) push_value(L, idx[i]);
  lua_call(L, n, 1);
}

/* Is the condition at idx (checked by the jets' call already) true? */
static int holds(lua_State *L, int idx)
{
  if (lua_type(L, idx) == LUA_TNUMBER) return lua_tonumber(L, idx) != 0.0;
  return value_at(L, idx) != 0.0;
}

/* The value of a selection is on top; make it a dualjet whose eta-part is
 * that of the operand chosen (zero for a number or a jet) when one of the
 * candidates cand[0..n-1] is a dualjet, over the eta shape of those. */
static int selection(lua_State *L, int chosen, const int *cand, int n)
{
  nz_jet *r = nz_lua_tojet(L, -1);
  if (!r) return 1;
  int eo = r->order, en = r->ntan, any = 0;
  for (int i = 0; i < n; i++) {
    dualjet *x = todual(L, cand[i]);
    if (!x) continue;
    any = 1;
    eo = imin(eo, x->d->order);
    en = imax(en, x->d->ntan);
  }
  if (!any) return 1;
  dualjet *c = todual(L, chosen), *z = new_dual(L, r->order, r->ntan, eo, en);
  nz_jet_copy(z->v, r);
  nz_jet_copy_fit(z->d, c ? c->d : NULL);
  return 1;
}

static int branch_dispatch(lua_State *L, int n, const char *fname)
{
  lua_settop(L, n);
  for (int i = 1; i <= n; i++)
    if (lua_type(L, i) == LUA_TTABLE) return nz_lua_dispatch(L, n, fname, 0);
  return 0;
}

/* lt, le, gt, ge: 1 or 0 by the jets' branch rule on the value parts. */
static int comparison(lua_State *L, const char *fname)
{
  if (branch_dispatch(L, 2, fname)) return 1;
  call_jets(L, fname, 2, (const int[]){ 1, 2 });
  return 1;
}

static int dj_lt_fn(lua_State *L) { return comparison(L, "lt"); }
static int dj_le_fn(lua_State *L) { return comparison(L, "le"); }
static int dj_gt_fn(lua_State *L) { return comparison(L, "gt"); }
static int dj_ge_fn(lua_State *L) { return comparison(L, "ge"); }

static int dj_ifelse(lua_State *L)
{
  if (branch_dispatch(L, 3, "ifelse")) return 1;
  call_jets(L, "ifelse", 3, (const int[]){ 1, 2, 3 });
  return selection(L, holds(L, 1) ? 2 : 3, (const int[]){ 2, 3 }, 2);
}

/* max = ifelse(ge(a, b), a, b), min = ifelse(le(a, b), a, b). */
static int extremum(lua_State *L, const char *fname, const char *cmp)
{
  if (branch_dispatch(L, 2, fname)) return 1;
  call_jets(L, cmp, 2, (const int[]){ 1, 2 });
  int first = holds(L, 3);
  lua_pop(L, 1);
  call_jets(L, fname, 2, (const int[]){ 1, 2 });
  return selection(L, first ? 1 : 2, (const int[]){ 1, 2 }, 2);
}

static int dj_max(lua_State *L) { return extremum(L, "max", "ge"); }
static int dj_min(lua_State *L) { return extremum(L, "min", "le"); }

/* clamp(x, lo, hi): lo where x < lo, hi where x > hi, else x.  The jets'
 * clamp checks lo <= hi and gives the value; the operand chosen follows
 * from the comparisons of x with each bound (as the graph records it). */
static int dj_clamp(lua_State *L)
{
  if (branch_dispatch(L, 3, "clamp")) return 1;
  call_jets(L, "lt", 2, (const int[]){ 1, 2 });
  int below = holds(L, 4);
  lua_pop(L, 1);
  call_jets(L, "gt", 2, (const int[]){ 1, 3 });
  int above = holds(L, 4);
  lua_pop(L, 1);
  call_jets(L, "clamp", 3, (const int[]){ 1, 2, 3 });
  return selection(L, above ? 3 : below ? 2 : 1, (const int[]){ 1, 2, 3 }, 3);
}

/* ------------------------------------------------------------------ */
/* Methods, printing, construction (for tests)                          */

static void push_jet_of(lua_State *L, const nz_jet *j)
{
  nz_jet_copy(nz_lua_newjet(L, j->order, j->ntan), j);
}

/* x:parts() -> v, d as jets (copies). */
static int dj_parts(lua_State *L)
{
  dualjet *x = luaL_checkudata(L, 1, NZ_DUALJET_METATABLE);
  push_jet_of(L, x->v);
  push_jet_of(L, x->d);
  return 2;
}

static int dj_value(lua_State *L)
{
  lua_pushnumber(L, ((dualjet *)luaL_checkudata(L, 1, NZ_DUALJET_METATABLE))->v->c[0]);
  return 1;
}

static int dj_tostring(lua_State *L)
{
  dualjet *x = luaL_checkudata(L, 1, NZ_DUALJET_METATABLE);
  push_jet_of(L, x->v);
  const char *v = luaL_tolstring(L, -1, NULL);
  push_jet_of(L, x->d);
  const char *d = luaL_tolstring(L, -1, NULL);
  lua_pushfstring(L, "dualjet(%s + eta %s)", v, d);
  return 1;
}

/* A number or a jet at idx as a jet (a number: order 0 in scalar slot s). */
static const nz_jet *jet_arg(lua_State *L, int idx, int s)
{
  operand o;
  read_operand(L, idx, s, "dualjet", &o);
  if (o.d) luaL_argerror(L, idx, "number or jet expected, got a dualjet");
  return o.v;
}

/* core.mech.dualjet(v, d): v + eta d (a testing aid; the engine makes the
 * arguments of a function evaluated along a state direction itself). */
static int dj_new(lua_State *L)
{
  const nz_jet *v = jet_arg(L, 1, 0), *d = jet_arg(L, 2, 1);
  nz_lua_push_dualjet(L, v, d);
  return 1;
}

static const luaL_Reg dual_meta[] = {
  { "__add", dj_add }, { "__sub", dj_sub }, { "__mul", dj_mul }, { "__div", dj_div },
  { "__pow", dj_pow }, { "__unm", dj_unm }, { "__eq", dj_eq }, { "__lt", dj_lt }, { "__le", dj_le },
  { "__tostring", dj_tostring },
  /* the fields nz.sin(x), ..., nz.clamp(x, lo, hi) dispatch to */
  { "exp", dj_exp }, { "log", dj_log }, { "sqrt", dj_sqrt }, { "sin", dj_sin }, { "cos", dj_cos },
  { "tan", dj_tan }, { "asin", dj_asin }, { "acos", dj_acos }, { "atan", dj_atan },
  { "sinh", dj_sinh }, { "cosh", dj_cosh }, { "tanh", dj_tanh }, { "abs", dj_abs },
  { "sign", dj_sign }, { "atan2", dj_atan2 }, { "hypot", dj_hypot }, { "lt", dj_lt_fn },
  { "le", dj_le_fn }, { "gt", dj_gt_fn }, { "ge", dj_ge_fn }, { "ifelse", dj_ifelse },
  { "max", dj_max }, { "min", dj_min }, { "clamp", dj_clamp }, { NULL, NULL }
};

static const luaL_Reg dual_methods[] = { { "parts", dj_parts }, { "value", dj_value }, { NULL, NULL } };

void nz_lua_open_dualjet(lua_State *L)
{
  int core = lua_gettop(L);
  nz_lua_push_workspace(L, sizeof(dual_ws), workspace_gc);
  int ws = lua_gettop(L);
  if (luaL_newmetatable(L, NZ_DUALJET_METATABLE)) {
    lua_pushvalue(L, ws);
    lua_pushvalue(L, core);
    luaL_setfuncs(L, dual_meta, 2);
    lua_newtable(L);
    lua_pushvalue(L, ws);
    lua_pushvalue(L, core);
    luaL_setfuncs(L, dual_methods, 2);
    lua_setfield(L, -2, "__index");
  }
  lua_pop(L, 1);
  lua_getfield(L, core, "mech");
  lua_pushvalue(L, ws);
  lua_pushvalue(L, core);
  lua_pushcclosure(L, dj_new, 2);
  lua_setfield(L, -2, "dualjet");
  lua_settop(L, core);
}
