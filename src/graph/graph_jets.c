/* graph_jets.c - a plan evaluated on jets (see graph.h).
 *
 * Jet shapes of a call: an input's jet is used as given (by pointer); a
 * constant is exact to every order (a series c, 0, 0, ... without tangents);
 * a computed node has the lowest order of its non-constant operands and the
 * most tangents of all of them.  The eta-part of a node (din/dout) has the
 * node's order, lowered to that of its operands' eta-parts, and the most
 * tangents of the node and of those.  Outputs are copied into the shape the
 * caller set: missing coefficients and tangents are zero, extra ones are
 * dropped. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include "graph/graph_impl.h"

/* |x| = sign(x0) x, as nz_jet_apply (whose nz_jet_scale needs equal shapes). */
static nz_status jet_abs(nz_jet *z, const nz_jet *x)
{
  double x0 = x->c[0];
  if (x0 == 0.0 && (z->order >= 1 || z->ntan >= 1)) return NZ_ESING;
  return nz_jet_affine(z, x, x0 < 0.0 ? -1.0 : 1.0, 0.0);
}

/* The value jet of computed record jr into z. */
static nz_status jet_value(nz_graph_plan *p, const jrec *jr, nz_jet *z)
{
  const nz_jet *A = p->J[jr->a], *B = p->J[jr->b];
  int ca = is_const_slot(p, jr->a), cb = is_const_slot(p, jr->b);
  double *w = p->w;
  switch (jr->op) {
  case NZ_GOP_ADD: return nz_jet_add(z, A, B);
  case NZ_GOP_SUB: return nz_jet_sub(z, A, B);
  case NZ_GOP_MUL:
    if (ca) return nz_jet_affine(z, B, p->vals[jr->a], 0.0);
    if (cb) return nz_jet_affine(z, A, p->vals[jr->b], 0.0);
    return nz_jet_mul(z, A, B, w);
  case NZ_GOP_DIV:
    if (cb) return nz_jet_div_const(z, A, p->vals[jr->b]);
    return nz_jet_div(z, A, B, w);
  case NZ_GOP_NEG: return nz_jet_affine(z, A, -1.0, 0.0);
  case NZ_GOP_POWC: return nz_jet_pow(z, A, jr->v, w);
  case NZ_GOP_POW: return nz_jet_pow_jet(z, A, B, w);
  case NZ_GOP_FN:
    if (jr->fn == NZ_FN_ABS) return jet_abs(z, A);
    return nz_jet_apply(z, (nz_jet_fn)jr->fn, A, w);
  case NZ_GOP_ATAN2: return nz_jet_atan2(z, A, B, w);
  case NZ_GOP_HYPOT: return nz_jet_hypot(z, A, B, w);
  case NZ_GOP_CMP: return nz_jet_compare(z, (nz_cmp)jr->fn, A, B);
  case NZ_GOP_SELECT: return nz_jet_select(z, p->J[jr->c], A, B);
  default: return NZ_EDOM;
  }
}

/* The jets' eta rule of each operation (CONST, INPUT and CMP have none). */
static const nz_eta_op gop_eta[NZ_GOP_COUNT] = {
  [NZ_GOP_ADD] = NZ_ETA_ADD, [NZ_GOP_SUB] = NZ_ETA_SUB, [NZ_GOP_MUL] = NZ_ETA_MUL,
  [NZ_GOP_DIV] = NZ_ETA_DIV, [NZ_GOP_NEG] = NZ_ETA_NEG, [NZ_GOP_POWC] = NZ_ETA_POWC,
  [NZ_GOP_POW] = NZ_ETA_POW, [NZ_GOP_FN] = NZ_ETA_FN, [NZ_GOP_ATAN2] = NZ_ETA_ATAN2,
  [NZ_GOP_HYPOT] = NZ_ETA_HYPOT,
};

/* The eta-part of computed slot s into Ez, by the rules of d_rule on jets
 * (jets/jet_eta.c); a constant slot scales or divides by its value. */
static nz_status jet_eta(nz_graph_plan *p, int s, const jrec *jr, nz_jet *Ez)
{
  const nz_jet *dA = p->E[jr->a], *dB = unary_op(jr->op) ? NULL : p->E[jr->b];
  if (jr->op == NZ_GOP_SELECT) {   /* the eta-part of the branch taken (NULL: zero) */
    nz_jet_copy_fit(Ez, p->J[jr->c]->c[0] != 0.0 ? dA : dB);
    return NZ_OK;
  }
  nz_eta_args x = { gop_eta[jr->op], (nz_jet_fn)jr->fn, jr->v, p->J[jr->a], p->J[jr->b], p->J[s],
                    dA, dB, is_const_slot(p, jr->a), is_const_slot(p, jr->b) };
  return nz_jet_eta(Ez, &x, p->T, p->w);
}

static size_t jet_doubles(int order, int ntan)
{
  size_t hdr = (sizeof(nz_jet) + sizeof(double) - 1) / sizeof(double);
  return hdr + ((size_t)order + 1) * ((size_t)ntan + 1);
}

/* Place a jet of this shape at *at (a cursor in the arena). */
static nz_jet *place(double **at, int order, int ntan)
{
  nz_jet *z = (nz_jet *)(void *)*at;
  z->order = order;
  z->ntan = ntan;
  *at += jet_doubles(order, ntan);
  return z;
}

/* Shapes of this call: inputs as given, constants of the highest order with
 * no tangents (exact to every order), a computed node the lowest order of its
 * non-constant operands and the most tangents; the eta-part likewise, over
 * the operands whose eta-part is not zero.  Returns the arena length. */
static size_t plan_shapes(nz_graph_plan *p, int eta, int Kmax, int *Dmax)
{
  size_t len = 0;
  for (int s = p->nin; s < p->base; s++) {
    p->ord[s] = Kmax;
    p->ntn[s] = 0;
    p->eord[s] = -1;
    len += jet_doubles(Kmax, 0);
  }
  for (int i = 0; i < p->nrec; i++) {
    const jrec *jr = &p->jrecs[i];
    int s = p->base + i, a = jr->a, b = jr->b, ka = !is_const_slot(p, a), kb = !is_const_slot(p, b);
    int o = ka && kb ? imin(p->ord[a], p->ord[b]) : ka ? p->ord[a] : kb ? p->ord[b] : Kmax;
    /* A step (cmp, sign) is a constant series with no eta-part; its
     * tangents are zeros in the operands' shape, as the jets make it (the
     * shape says whether a function after it wants derivatives: sqrt of
     * gt(x, 0) at 0 refuses as in Lua). */
    int step = jr->op == NZ_GOP_CMP || (jr->op == NZ_GOP_FN && jr->fn == NZ_FN_SIGN);
    p->ord[s] = o;
    p->ntn[s] = imax(p->ntn[a], p->ntn[b]);
    len += jet_doubles(o, p->ntn[s]);
    p->eord[s] = -1;
    if (!eta || step) continue;
    int ea = p->eord[a] >= 0, eb = !unary_op(jr->op) && p->eord[b] >= 0;
    if (!ea && !eb) continue;
    p->eord[s] = imin(o, imin(ea ? p->eord[a] : o, eb ? p->eord[b] : o));
    p->entn[s] = imax(p->ntn[s], imax(ea ? p->entn[a] : 0, eb ? p->entn[b] : 0));
    len += jet_doubles(p->eord[s], p->entn[s]);
    *Dmax = imax(*Dmax, p->entn[s]);
  }
  return len;
}

nz_status nz_graph_eval_jets(nz_graph_plan *p, const nz_jet *const *in, nz_jet *const *out,
                             const nz_jet *const *din, nz_jet *const *dout)
{
  int eta = din != NULL && dout != NULL, Kmax = -1, Dmax = 0;
  p->fail_node = -1;
  if (p->bad_const >= 0) return nz_graph_plan_fail(p, p->bad_const, d_finite(p->vals[p->bad_const]), p->vals[p->bad_const]);
  for (int s = 0; s < p->nin; s++) {
    const nz_jet *x = in ? in[p->in_num[s]] : NULL;
    if (!x) return nz_graph_plan_fail(p, s, NZ_EDOM, NAN);   /* a used input has no jet */
    p->J[s] = x;
    p->ord[s] = x->order;
    p->ntn[s] = x->ntan;
    Kmax = imax(Kmax, x->order);
    Dmax = imax(Dmax, x->ntan);
    const nz_jet *e = eta ? din[p->in_num[s]] : NULL;
    p->E[s] = e;
    p->eord[s] = e ? e->order : -1;
    if (e) {
      p->entn[s] = e->ntan;
      Dmax = imax(Dmax, e->ntan);
    }
  }
  if (Kmax < 0)   /* no inputs: constant expressions, to the outputs' order */
    for (int r = 0; r < p->nout; r++) Kmax = imax(Kmax, out[r]->order);
  if (Kmax < 0) Kmax = 0;
  size_t len = plan_shapes(p, eta, Kmax, &Dmax);
  len += NTEMP * jet_doubles(Kmax, Dmax) + nz_jet_work_len(Kmax);
  if (len > p->arena_len) {
    free(p->arena);
    p->arena = malloc(len * sizeof(double));
    p->arena_len = p->arena ? len : 0;
    if (!p->arena) return NZ_ENOMEM;
  }
  /* Lay the jets out (no allocation from here on). */
  double *at = p->arena;
  for (int s = p->nin; s < p->base; s++) {
    nz_jet *c = place(&at, Kmax, 0);
    nz_jet_set_constant(c, p->vals[s]);
    p->J[s] = c;
    p->E[s] = NULL;
  }
  for (int s = p->base; s < p->m; s++) {
    p->W[s] = place(&at, p->ord[s], p->ntn[s]);
    p->J[s] = p->W[s];
    p->EW[s] = p->eord[s] >= 0 ? place(&at, p->eord[s], p->entn[s]) : NULL;
    p->E[s] = NULL;   /* set once computed */
  }
  for (int i = 0; i < NTEMP; i++) p->T[i] = place(&at, Kmax, Dmax);
  p->w = at;
  /* Evaluate node by node. */
  for (int i = 0; i < p->nrec; i++) {
    const jrec *jr = &p->jrecs[i];
    int s = p->base + i;
    nz_status st = jet_value(p, jr, p->W[s]);
    if (!st && p->EW[s]) {
      st = jet_eta(p, s, jr, p->EW[s]);
      p->E[s] = p->EW[s];
    }
    if (st) return nz_graph_plan_fail(p, s, st, p->J[jr->a]->c[0]);
  }
  for (int r = 0; r < p->nout; r++) {
    nz_jet_copy_fit(out[r], p->J[p->out_slot[r]]);
    if (eta) nz_jet_copy_fit(dout[r], p->E[p->out_slot[r]]);
  }
  return NZ_OK;
}

