/* graph_diff.c - forward differentiation on the graph (nz_graph_diff*),
 * copies and substitutions of graphs (see graph.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include "graph/graph_impl.h"

/* ------------------------------------------------------------------ */
/* Forward differentiation on the graph                                 */

/* Derivative node ids; DZERO is an exact zero (nothing moves the node). */
#define DZERO (-1)

typedef struct dctx {
  nz_graph *g;
  int oom;   /* a build failed: the whole derivative fails */
} dctx;

/* A value node just built (flag a failure). */
static int V(dctx *c, int id)
{
  if (id < 0) c->oom = 1;
  return id;
}
/* A derivative node just built: constant zero becomes DZERO. */
static int Dk(dctx *c, int id)
{
  if (id < 0) { c->oom = 1; return DZERO; }
  return is_const_value(c->g, id, 0.0) ? DZERO : id;
}
static int d_neg(dctx *c, int x) { return x == DZERO ? DZERO : Dk(c, nz_graph_op(c->g, NZ_GOP_NEG, x, -1)); }
static int d_add(dctx *c, int x, int y)
{
  if (x == DZERO) return y;
  if (y == DZERO) return x;
  return Dk(c, nz_graph_op(c->g, NZ_GOP_ADD, x, y));
}
static int d_sub(dctx *c, int x, int y)
{
  if (y == DZERO) return x;
  if (x == DZERO) return d_neg(c, y);
  return Dk(c, nz_graph_op(c->g, NZ_GOP_SUB, x, y));
}
/* One factor a value node (or a failed build, -1), the other anything. */
static int d_mul(dctx *c, int x, int y)
{
  if (x == DZERO || y == DZERO) return DZERO;
  return Dk(c, nz_graph_op(c->g, NZ_GOP_MUL, x, y));
}
static int d_div(dctx *c, int x, int y)
{
  if (x == DZERO || y < 0) return DZERO;
  return Dk(c, nz_graph_op(c->g, NZ_GOP_DIV, x, y));
}
static int v_const(dctx *c, double v) { return V(c, nz_graph_const(c->g, v)); }
static int v_op(dctx *c, nz_gop op, int a, int b) { return V(c, nz_graph_op(c->g, op, a, b)); }
static int v_fn(dctx *c, nz_jet_fn fn, int a) { return V(c, nz_graph_fn(c->g, fn, a)); }
static int v_sq(dctx *c, int a) { return V(c, nz_graph_powc(c->g, a, 2.0)); }

/* d fn(a) = fn'(a) da, z = fn(a). */
static int d_fn_rule(dctx *c, nz_jet_fn fn, int a, int z, int da)
{
  switch (fn) {
  case NZ_FN_EXP: return d_mul(c, z, da);
  case NZ_FN_LOG: return d_div(c, da, a);
  case NZ_FN_SQRT: return d_div(c, da, v_op(c, NZ_GOP_MUL, v_const(c, 2.0), z));
  case NZ_FN_SIN: return d_mul(c, v_fn(c, NZ_FN_COS, a), da);
  case NZ_FN_COS: return d_neg(c, d_mul(c, v_fn(c, NZ_FN_SIN, a), da));
  case NZ_FN_TAN: return d_mul(c, v_op(c, NZ_GOP_ADD, v_const(c, 1.0), v_sq(c, z)), da);
  case NZ_FN_ASIN:
  case NZ_FN_ACOS: {
    int r = v_fn(c, NZ_FN_SQRT, v_op(c, NZ_GOP_SUB, v_const(c, 1.0), v_sq(c, a)));
    int d = d_div(c, da, r);
    return fn == NZ_FN_ASIN ? d : d_neg(c, d);
  }
  case NZ_FN_ATAN: return d_div(c, da, v_op(c, NZ_GOP_ADD, v_const(c, 1.0), v_sq(c, a)));
  case NZ_FN_SINH: return d_mul(c, v_fn(c, NZ_FN_COSH, a), da);
  case NZ_FN_COSH: return d_mul(c, v_fn(c, NZ_FN_SINH, a), da);
  case NZ_FN_TANH: return d_mul(c, v_op(c, NZ_GOP_SUB, v_const(c, 1.0), v_sq(c, z)), da);
  case NZ_FN_ABS: return d_mul(c, v_op(c, NZ_GOP_DIV, a, z), da);   /* a/|a|: 0/0 at 0 */
  case NZ_FN_SIGN: return DZERO;   /* a step */
  default: c->oom = 1; return DZERO;
  }
}

/* The derivative of node z = nd given its operands' derivatives da, db. */
static int d_rule(dctx *c, const nz_gnode *nd, int z, int da, int db)
{
  int a = nd->a, b = nd->b;
  switch (nd->op) {
  case NZ_GOP_ADD: return d_add(c, da, db);
  case NZ_GOP_SUB: return d_sub(c, da, db);
  case NZ_GOP_NEG: return d_neg(c, da);
  case NZ_GOP_MUL: return d_add(c, d_mul(c, da, b), d_mul(c, a, db));
  case NZ_GOP_DIV:   /* (da - z db) / b */
    return d_div(c, d_sub(c, da, d_mul(c, z, db)), b);
  case NZ_GOP_POWC: {
    double p = nd->v;
    if (p == 1.0) return da;
    if (p == 0.0) return DZERO;   /* x^0 = 1 wherever x is defined */
    return d_mul(c, v_op(c, NZ_GOP_MUL, v_const(c, p), V(c, nz_graph_powc(c->g, a, p - 1.0))), da);
  }
  case NZ_GOP_POW: {   /* z (db log a + b da / a) */
    int t1 = d_mul(c, db, db == DZERO ? DZERO : v_fn(c, NZ_FN_LOG, a));
    int t2 = d_div(c, d_mul(c, b, da), a);
    return d_mul(c, z, d_add(c, t1, t2));
  }
  case NZ_GOP_FN: return d_fn_rule(c, (nz_jet_fn)nd->fn, a, z, da);
  case NZ_GOP_ATAN2: {   /* a = y, b = x: (x dy - y dx) / (x^2 + y^2) */
    int num = d_sub(c, d_mul(c, b, da), d_mul(c, a, db));
    if (num == DZERO) return DZERO;
    return d_div(c, num, v_op(c, NZ_GOP_ADD, v_sq(c, b), v_sq(c, a)));
  }
  case NZ_GOP_HYPOT:   /* (a da + b db) / z */
    return d_div(c, d_add(c, d_mul(c, a, da), d_mul(c, b, db)), z);
  case NZ_GOP_CMP: return DZERO;   /* a step */
  case NZ_GOP_SELECT: {   /* the derivative of the branch taken */
    int x = da == DZERO ? v_const(c, 0.0) : da, y = db == DZERO ? v_const(c, 0.0) : db;
    if (c->oom) return DZERO;
    return Dk(c, nz_graph_select(c->g, nd->c, x, y));
  }
  default: c->oom = 1; return DZERO;
  }
}

int nz_graph_derivatives(nz_graph *g, const int *roots, int nroots, const int *dinput, int *droots)
{
  int n = g->n, top = -1;
  if (nroots < 0) return -1;
  for (int r = 0; r < nroots; r++) {
    if (!valid(g, roots[r])) return -1;
    if (roots[r] > top) top = roots[r];
  }
  for (int i = 0; dinput && i < g->ninputs; i++)
    if (dinput[i] != -1 && !valid(g, dinput[i])) return -1;
  char *mark = calloc((size_t)top + 2, 1);
  int *d = malloc(((size_t)top + 2) * sizeof *d);
  dctx c = { g, 0 };
  if (!mark || !d) { free(mark); free(d); return -1; }
  for (int r = 0; r < nroots; r++) mark[roots[r]] = 1;
  int lo = top + 1;
  for (int id = top; id >= 0; id--) {
    if (!mark[id]) continue;
    lo = id;
    const nz_gnode *nd = &g->nodes[id];
    if (has_operand(nd->op)) mark[nd->a] = 1;
    if (binary_op(nd->op)) mark[nd->b] = 1;
  }
  /* Ids above n are the derivative's own nodes: never revisited. */
  for (int id = lo; id <= top && id < n && !c.oom; id++) {
    if (!mark[id]) continue;
    nz_gnode nd = g->nodes[id];   /* a copy: building may move g->nodes */
    if (nd.op == NZ_GOP_CONST) { d[id] = DZERO; continue; }
    if (nd.op == NZ_GOP_INPUT) {
      int di = dinput && nd.a < g->ninputs ? dinput[nd.a] : -1;
      d[id] = di < 0 || is_const_value(g, di, 0.0) ? DZERO : di;
      continue;
    }
    int da = d[nd.a], db = binary_op(nd.op) ? d[nd.b] : DZERO;
    d[id] = da == DZERO && db == DZERO ? DZERO : d_rule(&c, &nd, id, da, db);
  }
  for (int r = 0; r < nroots && !c.oom; r++) {
    int x = d[roots[r]];
    droots[r] = x == DZERO ? v_const(&c, 0.0) : x;
  }
  free(mark);
  free(d);
  return c.oom ? -1 : 0;
}

int nz_graph_derivative(nz_graph *g, int root, const int *dinput)
{
  int dr;
  return nz_graph_derivatives(g, &root, 1, dinput, &dr) ? -1 : dr;
}

/* ------------------------------------------------------------------ */
/* Copies and substitutions                                             */

int nz_graph_copy(nz_graph *dst, const nz_graph *src, const int *roots, int nroots, const int *input_map,
                  int *out)
{
  int top = -1;
  if (nroots < 0) return -1;
  for (int r = 0; r < nroots; r++) {
    if (!valid(src, roots[r])) return -1;
    if (roots[r] > top) top = roots[r];
  }
  for (int i = 0; input_map && i < src->ninputs; i++)
    if (input_map[i] != -1 && !valid(dst, input_map[i])) return -1;
  char *mark = calloc((size_t)top + 2, 1);
  int *to = malloc(((size_t)top + 2) * sizeof *to);
  if (!mark || !to) { free(mark); free(to); return -1; }
  for (int r = 0; r < nroots; r++) mark[roots[r]] = 1;
  int lo = top + 1;
  for (int id = top; id >= 0; id--) {
    if (!mark[id]) continue;
    lo = id;
    const nz_gnode *nd = &src->nodes[id];
    if (has_operand(nd->op)) mark[nd->a] = 1;
    if (binary_op(nd->op)) mark[nd->b] = 1;
    if (has_cond(nd->op)) mark[nd->c] = 1;
  }
  /* With dst == src the new nodes come after top: never read here. */
  int ok = 1;
  for (int id = lo; id <= top && ok; id++) {
    if (!mark[id]) continue;
    nz_gnode nd = src->nodes[id];   /* a copy: building may move src->nodes when dst == src */
    int x;
    switch (nd.op) {
    case NZ_GOP_CONST: x = nz_graph_const(dst, nd.v); break;
    case NZ_GOP_INPUT: {
      int m = input_map && nd.a < src->ninputs ? input_map[nd.a] : -1;
      x = m >= 0 ? m : nz_graph_input(dst, nd.a);
      break;
    }
    case NZ_GOP_NEG: x = nz_graph_op(dst, NZ_GOP_NEG, to[nd.a], -1); break;
    case NZ_GOP_POWC: x = nz_graph_powc(dst, to[nd.a], nd.v); break;
    case NZ_GOP_FN: x = nz_graph_fn(dst, (nz_jet_fn)nd.fn, to[nd.a]); break;
    case NZ_GOP_CMP: x = nz_graph_cmp(dst, (nz_cmp)nd.fn, to[nd.a], to[nd.b]); break;
    case NZ_GOP_SELECT: x = nz_graph_select(dst, to[nd.c], to[nd.a], to[nd.b]); break;
    default: x = nz_graph_op(dst, (nz_gop)nd.op, to[nd.a], to[nd.b]); break;
    }
    if (x < 0) ok = 0;
    to[id] = x;
  }
  for (int r = 0; r < nroots && ok; r++) out[r] = to[roots[r]];
  free(mark);
  free(to);
  return ok ? 0 : -1;
}

