/* jet_eta.c - the eta-part of each jet operation (see jet_eta.h).
 *
 * Each rule is the derivative of the operation (the same rules as the
 * graph's forward differentiation, d_rule in graph_diff.c) written in jet
 * arithmetic: dz = f'(a) da for a function, (da - z db) / b for a quotient,
 * ...  A zero eta-part (NULL) is skipped rather than multiplied, so an
 * operand off the direction costs nothing. */
#include <string.h>
#include "jets/jet_eta.h"

nz_status nz_jet_affine(nz_jet *z, const nz_jet *x, double s, double c)
{
  size_t len = (size_t)z->order + 1;
  for (int d = -1; d < z->ntan; d++) {
    double *zd = d < 0 ? z->c : nz_jet_tangent(z, d);
    const double *xd = d < 0 ? x->c : nz_jet_tangent(x, d);
    if (!xd) memset(zd, 0, len * sizeof *zd);
    else for (size_t k = 0; k < len; k++) zd[k] = s * xd[k];
  }
  if (c != 0.0) z->c[0] += c;
  return nz_jet_check_finite(z);
}

nz_status nz_jet_div_const(nz_jet *z, const nz_jet *x, double c)
{
  if (c == 0.0) return NZ_EZERODIV;
  size_t len = (size_t)z->order + 1;
  for (int d = -1; d < z->ntan; d++) {
    double *zd = d < 0 ? z->c : nz_jet_tangent(z, d);
    const double *xd = d < 0 ? x->c : nz_jet_tangent(x, d);
    if (!xd) memset(zd, 0, len * sizeof *zd);
    else for (size_t k = 0; k < len; k++) zd[k] = xd[k] / c;
  }
  return nz_jet_check_finite(z);
}

void nz_jet_copy_fit(nz_jet *z, const nz_jet *src)
{
  for (int d = -1; d < z->ntan; d++) {
    double *zd = d < 0 ? z->c : nz_jet_tangent(z, d);
    const double *sd = !src ? NULL : d < 0 ? src->c : nz_jet_tangent(src, d);
    int k = 0, kc = sd ? (z->order < src->order ? z->order : src->order) : -1;
    for (; k <= kc; k++) zd[k] = sd[k];
    for (; k <= z->order; k++) zd[k] = 0.0;
  }
}

/* fn'(a) da, z = fn(a). */
static nz_status eta_fn(nz_jet_fn fn, nz_jet *Ez, const nz_jet *A, const nz_jet *Z,
                        const nz_jet *dA, nz_jet *const T[4], double *w)
{
  nz_jet *T0 = T[0], *T1 = T[1], *T2 = T[2];
  nz_status st;
  switch (fn) {
  case NZ_FN_EXP: return nz_jet_mul(Ez, Z, dA, w);
  case NZ_FN_LOG: return nz_jet_div(Ez, dA, A, w);
  case NZ_FN_SQRT:
    if ((st = nz_jet_affine(T0, Z, 2.0, 0.0))) return st;
    return nz_jet_div(Ez, dA, T0, w);
  case NZ_FN_SIN:
  case NZ_FN_SINH:
    if ((st = nz_jet_apply(T0, fn == NZ_FN_SIN ? NZ_FN_COS : NZ_FN_COSH, A, w))) return st;
    return nz_jet_mul(Ez, T0, dA, w);
  case NZ_FN_COSH:
    if ((st = nz_jet_apply(T0, NZ_FN_SINH, A, w))) return st;
    return nz_jet_mul(Ez, T0, dA, w);
  case NZ_FN_COS:
    if ((st = nz_jet_apply(T0, NZ_FN_SIN, A, w)) || (st = nz_jet_mul(T1, T0, dA, w))) return st;
    return nz_jet_affine(Ez, T1, -1.0, 0.0);
  case NZ_FN_TAN:
  case NZ_FN_TANH:   /* (1 +- z^2) da */
    if ((st = nz_jet_mul(T0, Z, Z, w)) ||
        (st = nz_jet_affine(T1, T0, fn == NZ_FN_TAN ? 1.0 : -1.0, 1.0)))
      return st;
    return nz_jet_mul(Ez, T1, dA, w);
  case NZ_FN_ATAN:
    if ((st = nz_jet_mul(T0, A, A, w)) || (st = nz_jet_affine(T1, T0, 1.0, 1.0))) return st;
    return nz_jet_div(Ez, dA, T1, w);
  case NZ_FN_ASIN:
  case NZ_FN_ACOS:   /* +- da / sqrt(1 - a^2) */
    if ((st = nz_jet_mul(T0, A, A, w)) || (st = nz_jet_affine(T1, T0, -1.0, 1.0)) ||
        (st = nz_jet_apply(T0, NZ_FN_SQRT, T1, w)))
      return st;
    if (fn == NZ_FN_ASIN) return nz_jet_div(Ez, dA, T0, w);
    if ((st = nz_jet_div(T2, dA, T0, w))) return st;
    return nz_jet_affine(Ez, T2, -1.0, 0.0);
  case NZ_FN_ABS:   /* sign(a) da, undefined at 0 */
    if (A->c[0] == 0.0) return NZ_ESING;
    return nz_jet_affine(Ez, dA, A->c[0] < 0.0 ? -1.0 : 1.0, 0.0);
  default: return NZ_EDOM;   /* sign is a step: no eta-part */
  }
}

/* z (db log a + b da / a) */
static nz_status eta_pow(nz_jet *Ez, const nz_eta_args *x, nz_jet *const T[4], double *w)
{
  const nz_jet *A = x->a, *B = x->b, *dA = x->da, *dB = x->db, *sum;
  nz_status st;
  if (dB && ((st = nz_jet_apply(T[0], NZ_FN_LOG, A, w)) || (st = nz_jet_mul(T[1], dB, T[0], w))))
    return st;
  if (dA && ((st = nz_jet_div(T[0], dA, A, w)) || (st = nz_jet_mul(T[2], B, T[0], w)))) return st;
  if (dA && dB) {
    if ((st = nz_jet_add(T[3], T[1], T[2]))) return st;
    sum = T[3];
  } else sum = dA ? T[2] : T[1];
  return nz_jet_mul(Ez, x->z, sum, w);
}

/* a = y, b = x: (x dy - y dx) / (x^2 + y^2) */
static nz_status eta_atan2(nz_jet *Ez, const nz_eta_args *x, nz_jet *const T[4], double *w)
{
  const nz_jet *A = x->a, *B = x->b, *dA = x->da, *dB = x->db;
  nz_status st;
  if (dA && dB) {
    if ((st = nz_jet_mul(T[0], B, dA, w)) || (st = nz_jet_mul(T[1], A, dB, w)) ||
        (st = nz_jet_sub(T[2], T[0], T[1])))
      return st;
  } else if (dA) {
    if ((st = nz_jet_mul(T[2], B, dA, w))) return st;
  } else if ((st = nz_jet_mul(T[1], A, dB, w)) || (st = nz_jet_affine(T[2], T[1], -1.0, 0.0)))
    return st;
  if ((st = nz_jet_mul(T[0], A, A, w)) || (st = nz_jet_mul(T[1], B, B, w)) ||
      (st = nz_jet_add(T[3], T[0], T[1])))
    return st;
  return nz_jet_div(Ez, T[2], T[3], w);
}

nz_status nz_jet_eta(nz_jet *ez, const nz_eta_args *x, nz_jet *const tmp[4], double *w)
{
  const nz_jet *A = x->a, *B = x->b, *Z = x->z, *dA = x->da, *dB = x->db;
  nz_jet *const *T = tmp;
  nz_status st;
  for (int i = 0; i < 4; i++) {
    tmp[i]->order = ez->order;
    tmp[i]->ntan = ez->ntan;
  }
  if (!dA && !dB) return nz_jet_affine(ez, A, 0.0, 0.0);   /* zero */
  switch (x->op) {
  case NZ_ETA_ADD:
    if (dA && dB) return nz_jet_add(ez, dA, dB);
    return nz_jet_affine(ez, dA ? dA : dB, 1.0, 0.0);
  case NZ_ETA_SUB:
    if (dA && dB) return nz_jet_sub(ez, dA, dB);
    return dA ? nz_jet_affine(ez, dA, 1.0, 0.0) : nz_jet_affine(ez, dB, -1.0, 0.0);
  case NZ_ETA_NEG: return nz_jet_affine(ez, dA, -1.0, 0.0);
  case NZ_ETA_MUL:
    if (x->ca) return nz_jet_affine(ez, dB, A->c[0], 0.0);
    if (x->cb) return nz_jet_affine(ez, dA, B->c[0], 0.0);
    if (!dB) return nz_jet_mul(ez, dA, B, w);
    if (!dA) return nz_jet_mul(ez, A, dB, w);
    if ((st = nz_jet_mul(T[0], dA, B, w)) || (st = nz_jet_mul(T[1], A, dB, w))) return st;
    return nz_jet_add(ez, T[0], T[1]);
  case NZ_ETA_DIV:   /* (da - z db) / b */
    if (x->cb) return nz_jet_div_const(ez, dA, B->c[0]);
    if (!dB) return nz_jet_div(ez, dA, B, w);
    if ((st = nz_jet_mul(T[0], Z, dB, w))) return st;
    if ((st = dA ? nz_jet_sub(T[1], dA, T[0]) : nz_jet_affine(T[1], T[0], -1.0, 0.0))) return st;
    return nz_jet_div(ez, T[1], B, w);
  case NZ_ETA_POWC:   /* p a^(p-1) da; a^0 is the constant 1 */
    if (x->p == 0.0) return nz_jet_affine(ez, dA, 0.0, 0.0);
    if ((st = nz_jet_pow(T[0], A, x->p - 1.0, w)) || (st = nz_jet_affine(T[1], T[0], x->p, 0.0)))
      return st;
    return nz_jet_mul(ez, T[1], dA, w);
  case NZ_ETA_POW: return eta_pow(ez, x, T, w);
  case NZ_ETA_FN: return eta_fn(x->fn, ez, A, Z, dA, T, w);
  case NZ_ETA_ATAN2: return eta_atan2(ez, x, T, w);
  case NZ_ETA_HYPOT:   /* (a da + b db) / z */
    if (dA && dB) {
      if ((st = nz_jet_mul(T[0], A, dA, w)) || (st = nz_jet_mul(T[1], B, dB, w)) ||
          (st = nz_jet_add(T[2], T[0], T[1])))
        return st;
    } else if ((st = dA ? nz_jet_mul(T[2], A, dA, w) : nz_jet_mul(T[2], B, dB, w))) return st;
    return nz_jet_div(ez, T[2], Z, w);
  default: return NZ_EDOM;
  }
}
