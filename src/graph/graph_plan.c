/* graph_plan.c - plans of a graph and their evaluation on doubles (see
 * graph.h).
 *
 * Plans number their nodes in slots: inputs, constants, then the computed
 * nodes sorted by level and opcode (see sched_cmp).  Both evaluators run in
 * that order, so "the first failing node" is the same node on doubles and on
 * jets.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include "graph/graph_impl.h"

void nz_graph_plan_free(nz_graph_plan *p)
{
  if (!p) return;
  free(p->out_slot);
  free(p->ids);
  free(p->in_num);
  free(p->recs);
  free(p->runs);
  free(p->jrecs);
  free(p->pv);
  free(p->vals);
  free(p->J);
  free(p->E);
  free(p->W);
  free(p->EW);
  free(p->ord);
  free(p->ntn);
  free(p->eord);
  free(p->entn);
  free(p->arena);
  free(p->srecs);
  free(p->ser_aux);
  free(p->ser_map);
  free(p->ser);
  free(p->sruns);
  free(p->ser_v);
  free(p);
}

int nz_graph_plan_nodes(const nz_graph_plan *p) { return p->m; }
int nz_graph_plan_noutputs(const nz_graph_plan *p) { return p->nout; }

static grec make_grec(const nz_gnode *nd, int a, int b, int c)
{
  grec r = { 0, a, b, 0 };
  switch (nd->op) {
  case NZ_GOP_ADD: r.op = R_ADD; break;
  case NZ_GOP_SUB: r.op = R_SUB; break;
  case NZ_GOP_MUL: r.op = R_MUL; break;
  case NZ_GOP_DIV: r.op = R_DIV; break;
  case NZ_GOP_NEG: r.op = R_NEG; break;
  case NZ_GOP_POW: r.op = R_POW; break;
  case NZ_GOP_ATAN2: r.op = R_ATAN2; break;
  case NZ_GOP_HYPOT: r.op = R_HYPOT; break;
  case NZ_GOP_FN: r.op = R_FN; r.k = nd->fn; break;
  case NZ_GOP_CMP: r.op = R_CMP; r.k = nd->fn; break;
  case NZ_GOP_SELECT: r.op = R_SELECT; r.k = c; break;
  case NZ_GOP_POWC:
    if (nd->v == 2.0) r.op = R_SQR;
    else if (nd->v == 3.0) r.op = R_CUBE;
    else if (nd->v > 0.0 && is_small_integer(nd->v)) { r.op = R_POWI; r.k = (int32_t)nd->v; }
    else r.op = R_POWC;
    break;
  default: break;
  }
  return r;
}

/* The plan's arrays (p comes from calloc: on failure those not allocated
 * are NULL, and nz_graph_plan_free frees the others). */
static int plan_alloc(nz_graph_plan *p)
{
  size_t m = (size_t)p->m + 1, nr = (size_t)p->nrec + 1, ni = (size_t)p->nin + 1;
#define ALLOC(f, n) ((p->f = malloc((n) * sizeof *p->f)) != NULL)
  int ok = ALLOC(ids, m) && ALLOC(in_num, ni) && ALLOC(recs, nr) && ALLOC(runs, nr) &&
           ALLOC(jrecs, nr) && ALLOC(pv, nr) && ALLOC(vals, m) && ALLOC(J, m) && ALLOC(E, m) &&
           ALLOC(W, m) && ALLOC(EW, m) && ALLOC(ord, m) && ALLOC(ntn, m) && ALLOC(eord, m) &&
           ALLOC(entn, m);
#undef ALLOC
  return ok ? 0 : -1;
}

/* Scheduling: computed nodes sorted by level (1 + the highest level of
 * their operands), then by opcode, then by id.  Any order by level is
 * topological; within a level, nodes of one opcode come together, so the
 * double loop dispatches once per run of them and the runs' nodes are
 * independent (the processor overlaps them). */
typedef struct sched {
  int level, key, id;
} sched;

static int sched_cmp(const void *x, const void *y)
{
  const sched *u = x, *w = y;
  if (u->level != w->level) return u->level < w->level ? -1 : 1;
  if (u->key != w->key) return u->key < w->key ? -1 : 1;
  return (u->id > w->id) - (u->id < w->id);
}

/* Mark what the outputs need; lev[id] = level + 1 for a needed node, 0 for
 * the others.  Counts the plan's slots. */
static void plan_mark(nz_graph_plan *p, const nz_graph *g, const int *outputs, int n, int top,
                      int *lev)
{
  for (int id = 0; id <= top; id++) lev[id] = 0;
  for (int r = 0; r < n; r++) lev[outputs[r]] = 1;
  for (int id = top; id >= 0; id--) {
    if (!lev[id]) continue;
    const nz_gnode *nd = &g->nodes[id];
    if (has_operand(nd->op)) lev[nd->a] = 1;
    if (binary_op(nd->op)) lev[nd->b] = 1;
    if (has_cond(nd->op)) lev[nd->c] = 1;
    if (nd->op == NZ_GOP_INPUT) p->nin++;
    else if (nd->op == NZ_GOP_CONST) p->ncon++;
    else p->nrec++;
    p->m++;
  }
  for (int id = 0; id <= top; id++) {
    const nz_gnode *nd = &g->nodes[id];
    if (!lev[id] || !has_operand(nd->op)) continue;
    lev[id] = 1 + imax(imax(lev[nd->a], binary_op(nd->op) ? lev[nd->b] : 0),
                       has_cond(nd->op) ? lev[nd->c] : 0);
  }
}

nz_graph_plan *nz_graph_plan_new(const nz_graph *g, const int *outputs, int n)
{
  int top = -1;
  if (n < 0) return NULL;
  for (int r = 0; r < n; r++) {
    if (!valid(g, outputs[r])) return NULL;
    if (outputs[r] > top) top = outputs[r];
  }
  nz_graph_plan *p = calloc(1, sizeof *p);
  int *slot = malloc(((size_t)top + 2) * sizeof *slot);
  if (!p || !slot) { free(p); free(slot); return NULL; }
  p->g = g;
  p->fail_node = -1;
  p->bad_const = -1;
  p->ser_naux = -1;
  p->ser_cap = -1;
  p->ser_k = -1;
  p->nout = n;
  p->out_slot = malloc(((size_t)n + 1) * sizeof *p->out_slot);
  plan_mark(p, g, outputs, n, top, slot);
  p->base = p->nin + p->ncon;
  sched *order = malloc(((size_t)p->nrec + 1) * sizeof *order);
  if (!order || !p->out_slot || plan_alloc(p)) {
    free(order);
    free(slot);
    nz_graph_plan_free(p);
    return NULL;
  }
  /* Slots: inputs and constants in id order, then computed nodes as
   * scheduled (slot[] turns from levels into slots as it goes). */
  int si = 0, sc = p->nin, nr = 0;
  for (int id = 0; id <= top; id++) {
    const nz_gnode *nd = &g->nodes[id];
    if (!slot[id]) continue;
    if (nd->op == NZ_GOP_INPUT) {
      p->in_num[si] = nd->a;
      p->ids[si] = id;
      slot[id] = si++;
    } else if (nd->op == NZ_GOP_CONST) {
      p->vals[sc] = nd->v;
      if (!isfinite(nd->v) && p->bad_const < 0) p->bad_const = sc;
      p->ids[sc] = id;
      slot[id] = sc++;
    } else {
      grec r = make_grec(nd, 0, 0, 0);
      int sub = r.op == R_FN || r.op == R_CMP ? r.k : 0;
      order[nr++] = (sched){ slot[id], r.op * 64 + sub, id };
    }
  }
  qsort(order, (size_t)nr, sizeof *order, sched_cmp);
  for (int i = 0; i < nr; i++) {
    int id = order[i].id, s = p->base + i;
    const nz_gnode *nd = &g->nodes[id];
    int a = slot[nd->a], b = binary_op(nd->op) ? slot[nd->b] : a;
    int cs = has_cond(nd->op) ? slot[nd->c] : a;
    slot[id] = s;
    p->ids[s] = id;
    p->recs[i] = make_grec(nd, a, b, cs);
    p->jrecs[i] = (jrec){ nd->op, nd->fn, a, b, nd->v, cs };
    p->pv[i] = nd->v;
    if (p->nrun == 0 || p->runs[p->nrun - 1].op != p->recs[i].op) p->runs[p->nrun++].op = p->recs[i].op;
    p->runs[p->nrun - 1].end = i + 1;
  }
  for (int r = 0; r < n; r++) p->out_slot[r] = slot[outputs[r]];
  free(order);
  free(slot);
  return p;
}

void nz_graph_plan_failure(const nz_graph_plan *p, int *node, nz_gop *op, nz_jet_fn *fn,
                           double *operand)
{
  if (node) *node = p->fail_node;
  if (op) *op = p->fail_op;
  if (fn) *fn = p->fail_fn;
  if (operand) *operand = p->fail_operand;
}

/* Record the failure of slot s; operand: the value of its first operand. */
nz_status nz_graph_plan_fail(nz_graph_plan *p, int s, nz_status st, double operand)
{
  p->fail_node = p->ids[s];
  if (s < p->nin) { p->fail_op = NZ_GOP_INPUT; p->fail_fn = 0; }
  else if (s < p->base) { p->fail_op = NZ_GOP_CONST; p->fail_fn = 0; }
  else {
    p->fail_op = (nz_gop)p->jrecs[s - p->base].op;
    p->fail_fn = (nz_jet_fn)p->jrecs[s - p->base].fn;
  }
  p->fail_operand = operand;
  return st;
}

static int all_finite(const double *z, int n)
{
  /* Exponent bits all ones = inf or NaN; integer test so it vectorizes. */
  uint64_t bad = 0;
  for (int i = 0; i < n; i++) {
    uint64_t u;
    memcpy(&u, &z[i], sizeof u);
    bad |= (~u & 0x7ff0000000000000ULL) == 0;
  }
  return !bad;
}

/* The first non-finite computed slot before i, or -1. */
static int first_nonfinite(const double *z, int i)
{
  for (int j = 0; j < i; j++)
    if (!isfinite(z[j])) return j;
  return -1;
}

nz_status nz_graph_eval(nz_graph_plan *p, const double *in, double *out)
{
  double *v = p->vals, *z = v + p->base;
  const grec *r = p->recs;
  const double *pv = p->pv;
  int i, nr = p->nrec;
  nz_status st = NZ_OK;
  p->fail_node = -1;
  if (p->bad_const >= 0) return nz_graph_plan_fail(p, p->bad_const, d_finite(v[p->bad_const]), v[p->bad_const]);
  for (i = 0; i < p->nin; i++) v[i] = in[p->in_num[i]];
  /* The hot loop: one dispatch per run, no finiteness test per node (one
   * pass after it). */
  i = 0;
  for (int q = 0; q < p->nrun; q++) {
    int e = p->runs[q].end;
    switch (p->runs[q].op) {
    case R_ADD: for (; i < e; i++) z[i] = v[r[i].a] + v[r[i].b]; break;
    case R_SUB: for (; i < e; i++) z[i] = v[r[i].a] - v[r[i].b]; break;
    case R_MUL: for (; i < e; i++) z[i] = v[r[i].a] * v[r[i].b]; break;
    case R_DIV:
      for (; i < e; i++) {
        double y = v[r[i].b];
        if (y == 0.0) { st = NZ_EZERODIV; goto failed; }
        z[i] = v[r[i].a] / y;
      }
      break;
    case R_NEG: for (; i < e; i++) z[i] = -v[r[i].a]; break;
    case R_SQR: for (; i < e; i++) { double x = v[r[i].a]; z[i] = x * x; } break;
    case R_CUBE: for (; i < e; i++) { double x = v[r[i].a]; z[i] = x * x * x; } break;
    case R_POWI: for (; i < e; i++) z[i] = d_powi(v[r[i].a], (unsigned)r[i].k); break;
    case R_POWC:
      for (; i < e; i++)
        if ((st = d_powc(v[r[i].a], pv[i], &z[i]))) goto failed;
      break;
    case R_POW:
      for (; i < e; i++)
        if ((st = d_pow(v[r[i].a], v[r[i].b], &z[i]))) goto failed;
      break;
    case R_FN:
      for (; i < e; i++)
        if ((st = d_fn(r[i].k, v[r[i].a], &z[i]))) goto failed;
      break;
    case R_ATAN2: for (; i < e; i++) z[i] = atan2(v[r[i].a], v[r[i].b]); break;
    case R_HYPOT: for (; i < e; i++) z[i] = d_hypot(v[r[i].a], v[r[i].b]); break;
    case R_CMP:
      for (; i < e; i++)
        if ((st = d_cmp(r[i].k, v[r[i].a], v[r[i].b], &z[i]))) goto failed;
      break;
    case R_SELECT:   /* a NaN condition (an input, say) fails as nz_jet_select */
      for (; i < e; i++) {
        double c = v[r[i].k];
        if (isnan(c)) { st = NZ_ENAN; goto failed; }
        z[i] = c != 0.0 ? v[r[i].a] : v[r[i].b];
      }
      break;
    default: st = NZ_EDOM; goto failed;
    }
  }
  if (!all_finite(z, nr)) {
    int j = first_nonfinite(z, nr);
    return nz_graph_plan_fail(p, p->base + j, d_finite(z[j]), v[r[j].a]);
  }
  for (int o = 0; o < p->nout; o++) out[o] = v[p->out_slot[o]];
  return NZ_OK;

failed: {
    /* An earlier node that overflowed or gave NaN failed first. */
    int j = first_nonfinite(z, i);
    if (j >= 0) return nz_graph_plan_fail(p, p->base + j, d_finite(z[j]), v[r[j].a]);
    return nz_graph_plan_fail(p, p->base + i, st, v[r[i].a]);
  }
}

