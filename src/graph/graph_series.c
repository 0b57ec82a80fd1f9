/* graph_series.c - a plan's series built order by order (see graph.h,
 * and graph_series.h for the layout machine code reads).
 *
 * Series built order by order:
 * each computed node keeps its series, and the auxiliary series its kernel
 * needs, in one arena of the plan; begin picks each node's kernel once
 * coefficient 0 is known (the branch a select takes, the sign of abs, a
 * constant factor) and checks domains as the jets of that order would; next
 * runs the coefficient-level kernels of series.c, which are the jets' own
 * recurrences, so both give the same numbers.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include "graph/graph_impl.h"
#include "graph/graph_series.h"

/* The series kernels of a computed slot (graph_series.h) are chosen at
 * begin once coefficient 0 is known (a select's branch, the sign of abs, a
 * constant factor). */

/* One computed slot: z = its series, a and b its operands' (b = a for unary
 * ops; a = the chosen operand for NZ_SK_COPY), aux its auxiliary series; v a
 * constant factor (NZ_SK_SCALE: also -1 for neg, +-1 for abs), divisor (NZ_SK_DIVC),
 * exponent (NZ_SK_POWR) or scale (NZ_SK_HYPOT); n the exponent of NZ_SK_POWI. */
typedef struct srec {
  int op;
  unsigned n;
  const double *a, *b;
  double *z, *aux;
  double v;
} srec;

/* Auxiliary series a graph node needs (an upper bound over the kernels
 * begin may choose for it). */
static int series_aux_count(const jrec *jr)
{
  switch (jr->op) {
  case NZ_GOP_POWC:
    return jr->v > 0.0 && is_small_integer(jr->v) ? nz_series_powi_work((unsigned)jr->v) : 0;
  case NZ_GOP_POW: return 2;      /* log x, y log x */
  case NZ_GOP_ATAN2: return 1;    /* x^2 + y^2 */
  case NZ_GOP_HYPOT: return 4;    /* a/s, b/s, (a/s)^2 + (b/s)^2, its root */
  case NZ_GOP_FN:
    switch (jr->fn) {
    case NZ_FN_SIN: case NZ_FN_COS: case NZ_FN_SINH: case NZ_FN_COSH:
    case NZ_FN_TAN: case NZ_FN_TANH: case NZ_FN_ATAN:
      return 1;                   /* the companion, 1 +- t^2, 1 + x^2 */
    case NZ_FN_ASIN: case NZ_FN_ACOS:
      return 2;                   /* 1 - x^2, its root */
    default: return 0;
    }
  default: return 0;
  }
}

/* The layout (once per plan) and storage for order K (grown, never shrunk). */
static nz_status series_storage(nz_graph_plan *p, int K)
{
  if (p->ser_naux < 0) {
    int top = 0;
    size_t nr = (size_t)p->nrec + 1;
    for (int s = 0; s < p->m; s++) top = imax(top, p->ids[s]);
    p->ser_aux = malloc(nr * sizeof *p->ser_aux);
    p->srecs = malloc(nr * sizeof *p->srecs);
    p->sruns = malloc(nr * sizeof *p->sruns);
    p->ser_map = malloc(((size_t)top + 1) * sizeof *p->ser_map);
    p->ser_v = malloc(nr * sizeof *p->ser_v);
    if (!p->ser_aux || !p->srecs || !p->sruns || !p->ser_map || !p->ser_v) {   /* as if never tried */
      free(p->ser_aux);
      free(p->srecs);
      free(p->sruns);
      free(p->ser_map);
      free(p->ser_v);
      p->ser_aux = NULL;
      p->srecs = NULL;
      p->sruns = NULL;
      p->ser_map = NULL;
      p->ser_v = NULL;
      return NZ_ENOMEM;
    }
    int naux = 0;
    for (int i = 0; i < p->nrec; i++) {
      p->ser_aux[i] = naux;
      naux += series_aux_count(&p->jrecs[i]);
    }
    for (int id = 0; id <= top; id++) p->ser_map[id] = -1;
    for (int s = 0; s < p->m; s++) p->ser_map[p->ids[s]] = s;
    p->ser_top = top;
    p->ser_naux = naux;
  }
  if (K > p->ser_cap) {
    /* at least NZ_SERIES_MIN_ORDER: the same stride for every order up to
     * it, which machine code takes as a constant */
    if (K < NZ_SERIES_MIN_ORDER) K = NZ_SERIES_MIN_ORDER;
    size_t len = ((size_t)p->m + (size_t)p->ser_naux) * ((size_t)K + 1);
    double *ser = malloc((len ? len : 1) * sizeof *ser);
    if (!ser) return NZ_ENOMEM;
    free(p->ser);
    p->ser = ser;
    p->ser_cap = K;
  }
  return NZ_OK;
}

static double *series_of(const nz_graph_plan *p, int s)
{
  return p->ser + (size_t)s * ((size_t)p->ser_cap + 1);
}

/* Coefficient 0 of computed slot s = base + i, with the jets' domain checks
 * for order K (smooth: K >= 1 asks for derivatives), and its kernel. */
static nz_status series_first(nz_graph_plan *p, int i, int K)
{
  const jrec *jr = &p->jrecs[i];
  srec *r = &p->srecs[i];
  int s = p->base + i, smooth = K >= 1;
  double *z = series_of(p, s);
  const double *A = series_of(p, jr->a), *B = series_of(p, jr->b);
  double x = A[0], y = B[0];
  int ca = is_const_slot(p, jr->a), cb = is_const_slot(p, jr->b);
  double *aux = p->ser + ((size_t)p->m + (size_t)p->ser_aux[i]) * ((size_t)p->ser_cap + 1);
  *r = (srec){ NZ_SK_COPY, 0, A, B, z, aux, 0.0 };
  switch (jr->op) {
  case NZ_GOP_ADD: r->op = NZ_SK_ADD; break;
  case NZ_GOP_SUB: r->op = NZ_SK_SUB; break;
  case NZ_GOP_NEG: r->op = NZ_SK_SCALE; r->v = -1.0; break;
  case NZ_GOP_MUL:   /* a constant factor scales, as nz_jet_affine in the jets */
    if (ca || cb) {
      r->op = NZ_SK_SCALE;
      r->v = ca ? x : y;
      r->a = ca ? B : A;
    } else r->op = NZ_SK_MUL;
    break;
  case NZ_GOP_DIV:
    if (y == 0.0) return NZ_EZERODIV;
    r->op = cb ? NZ_SK_DIVC : NZ_SK_DIV;
    r->v = y;
    break;
  case NZ_GOP_POWC: {
    double pw = jr->v;
    int integer = is_small_integer(pw);
    if (pw == 0.0) { r->op = NZ_SK_STEP; z[0] = 1.0; return NZ_OK; }
    if (integer && pw > 0.0) {
      r->n = (unsigned)pw;
      r->op = r->n == 1 ? NZ_SK_COPY : r->n == 2 ? NZ_SK_SQR : NZ_SK_POWI;
      break;
    }
    if (x == 0.0) {   /* nz_jet_pow's order of checks */
      if (integer || (!smooth && pw < 0.0)) return NZ_EZERODIV;
      if (smooth) return NZ_ESING;
      r->op = NZ_SK_STEP;
      z[0] = 0.0;
      return NZ_OK;
    }
    if (x < 0.0 && !integer) return NZ_EDOM;
    r->op = NZ_SK_POWR;
    r->v = pw;
    break;
  }
  case NZ_GOP_POW:
    if (x < 0.0) return NZ_EDOM;
    if (x == 0.0) return NZ_ESING;
    r->op = NZ_SK_POW;
    break;
  case NZ_GOP_ATAN2:
    if (x == 0.0 && y == 0.0 && smooth) return NZ_ESING;
    r->op = NZ_SK_ATAN2;
    break;
  case NZ_GOP_HYPOT:
    r->v = fmax(fabs(x), fabs(y));
    if (r->v == 0.0) {
      if (smooth) return NZ_ESING;
      r->op = NZ_SK_STEP;
      z[0] = 0.0;
      return NZ_OK;
    }
    r->op = NZ_SK_HYPOT;
    break;
  case NZ_GOP_CMP: {
    nz_status st = d_cmp(jr->fn, x, y, &z[0]);
    if (st) return st;
    p->ser_ties += smooth && x == y;
    r->op = NZ_SK_STEP;
    return NZ_OK;
  }
  case NZ_GOP_SELECT: {
    double c = series_of(p, jr->c)[0];
    if (isnan(c)) return NZ_ENAN;
    r->a = c != 0.0 ? A : B;
    r->op = NZ_SK_COPY;
    break;
  }
  case NZ_GOP_FN:
    switch (jr->fn) {
    case NZ_FN_EXP: r->op = NZ_SK_EXP; break;
    case NZ_FN_LOG:
      if (!(x > 0.0)) return NZ_EDOM;
      r->op = NZ_SK_LOG;
      break;
    case NZ_FN_SQRT:
      if (x < 0.0) return NZ_EDOM;
      if (x == 0.0 && smooth) return NZ_ESING;
      r->op = NZ_SK_SQRT;
      break;
    case NZ_FN_SIN: r->op = NZ_SK_SIN; break;
    case NZ_FN_COS: r->op = NZ_SK_COS; break;
    case NZ_FN_SINH: r->op = NZ_SK_SINH; break;
    case NZ_FN_COSH: r->op = NZ_SK_COSH; break;
    case NZ_FN_TAN: r->op = NZ_SK_TAN; break;
    case NZ_FN_TANH: r->op = NZ_SK_TANH; break;
    case NZ_FN_ATAN: r->op = NZ_SK_ATAN; break;
    case NZ_FN_ASIN:
    case NZ_FN_ACOS:
      if (fabs(x) > 1.0) return NZ_EDOM;
      if (fabs(x) == 1.0 && smooth) return NZ_ESING;
      r->op = jr->fn == NZ_FN_ASIN ? NZ_SK_ASIN : NZ_SK_ACOS;
      break;
    case NZ_FN_ABS:
      if (x == 0.0 && smooth) return NZ_ESING;
      r->op = NZ_SK_SCALE;
      r->v = x < 0.0 ? -1.0 : 1.0;
      break;
    case NZ_FN_SIGN:
      if (isnan(x)) return NZ_ENAN;
      z[0] = (double)((x > 0.0) - (x < 0.0));
      p->ser_ties += smooth && x == 0.0;
      r->op = NZ_SK_STEP;
      return NZ_OK;
    default: return NZ_EDOM;
    }
    break;
  default: return NZ_EDOM;
  }
  return NZ_OK;
}

/* Coefficient k of r's series: the recurrences of jet.c, one coefficient at
 * a time (K: the storage's order, the stride of the auxiliary series). */
static inline void series_coef(const srec *r, int op, int k, int K)
{
  const double *a = r->a, *b = r->b;
  double *z = r->z, *w = r->aux, *w1 = w + K + 1, *w2 = w1 + K + 1, *w3 = w2 + K + 1;
  switch (op) {
  case NZ_SK_ADD: z[k] = a[k] + b[k]; break;
  case NZ_SK_SUB: z[k] = a[k] - b[k]; break;
  case NZ_SK_MUL: z[k] = nz_series_mul_coef(a, b, k); break;
  case NZ_SK_SCALE: z[k] = r->v * a[k]; break;
  case NZ_SK_DIV: z[k] = nz_series_div_coef(z, a, b, k); break;
  case NZ_SK_DIVC: z[k] = a[k] / r->v; break;
  case NZ_SK_SQR: z[k] = nz_series_mul_coef(a, a, k); break;
  case NZ_SK_POWI: z[k] = nz_series_powi_coef(w, a, r->n, k, K); break;
  case NZ_SK_POWR: z[k] = nz_series_pow_coef(z, a, r->v, k); break;
  case NZ_SK_POW:   /* exp(y log x) */
    w[k] = nz_series_log_coef(w, a, k);
    w1[k] = nz_series_mul_coef(b, w, k);
    z[k] = nz_series_exp_coef(z, w1, k);
    break;
  case NZ_SK_EXP: z[k] = nz_series_exp_coef(z, a, k); break;
  case NZ_SK_LOG: z[k] = nz_series_log_coef(z, a, k); break;
  case NZ_SK_SQRT: z[k] = nz_series_sqrt_coef(z, a, k); break;
  case NZ_SK_SIN: nz_series_sincos_coef(z, w, a, k, 0); break;
  case NZ_SK_COS: nz_series_sincos_coef(w, z, a, k, 0); break;
  case NZ_SK_SINH: nz_series_sincos_coef(z, w, a, k, 1); break;
  case NZ_SK_COSH: nz_series_sincos_coef(w, z, a, k, 1); break;
  case NZ_SK_TAN: nz_series_tan_coef(z, w, a, k, 0); break;
  case NZ_SK_TANH: nz_series_tan_coef(z, w, a, k, 1); break;
  case NZ_SK_ATAN:   /* y' (1 + x^2) = x' */
    w[k] = nz_series_mul_coef(a, a, k);
    if (k == 0) {
      w[0] += 1.0;
      z[0] = atan(a[0]);
    } else z[k] = nz_series_quadrature_coef(z, a, w, 1.0, k);
    break;
  case NZ_SK_ASIN:
  case NZ_SK_ACOS:   /* y' sqrt(1 - x^2) = +-x' */
    w[k] = -nz_series_mul_coef(a, a, k);
    if (k == 0) w[0] += 1.0;
    w1[k] = nz_series_sqrt_coef(w1, w, k);
    if (k == 0) z[0] = op == NZ_SK_ASIN ? asin(a[0]) : acos(a[0]);
    else z[k] = nz_series_quadrature_coef(z, a, w1, op == NZ_SK_ASIN ? 1.0 : -1.0, k);
    break;
  case NZ_SK_ATAN2:
    w[k] = nz_series_mul_coef(b, b, k) + nz_series_mul_coef(a, a, k);
    z[k] = nz_series_atan2_coef(z, a, b, w, k);
    break;
  case NZ_SK_HYPOT:   /* s sqrt((a/s)^2 + (b/s)^2), s = max(|a_0|, |b_0|) */
    w[k] = a[k] / r->v;
    w1[k] = b[k] / r->v;
    w2[k] = nz_series_mul_coef(w, w, k) + nz_series_mul_coef(w1, w1, k);
    w3[k] = nz_series_sqrt_coef(w3, w2, k);
    z[k] = w3[k] * r->v;
    break;
  case NZ_SK_STEP: if (k > 0) z[k] = 0.0; break;
  case NZ_SK_COPY: z[k] = a[k]; break;
  default: z[k] = NAN; break;
  }
}

/* Coefficient k of the inputs (NULL in: a used input without a value). */
static nz_status series_inputs(nz_graph_plan *p, const double *in, int k)
{
  for (int s = 0; s < p->nin; s++) {
    if (!in) return nz_graph_plan_fail(p, s, NZ_EDOM, NAN);
    series_of(p, s)[k] = in[p->in_num[s]];
  }
  return NZ_OK;
}

void nz_graph_series_inputs(nz_graph_plan *p, double **ptr, int n)
{
  for (int i = 0; i < n; i++) ptr[i] = NULL;
  if (p->ser_k < 0) return;
  for (int s = 0; s < p->nin; s++)
    if (p->in_num[s] < n) ptr[p->in_num[s]] = series_of(p, s);
}

/* Begin's work after the inputs and constants: each computed slot's
 * kernel and coefficient 0, with the jets' domain checks for order K. */
static nz_status series_first_all(nz_graph_plan *p, int K)
{
  nz_status st;
  for (int i = 0; i < p->nrec; i++) {
    int s = p->base + i;
    double *z = series_of(p, s);
    st = series_first(p, i, K);
    if (!st && p->srecs[i].op != NZ_SK_STEP) {
      series_coef(&p->srecs[i], p->srecs[i].op, 0, p->ser_cap);
      st = d_finite(z[0]);
    }
    if (st) return nz_graph_plan_fail(p, s, st, series_of(p, p->jrecs[i].a)[0]);
  }
  /* Runs of one kernel (the plan's schedule groups a level's nodes by
   * opcode): one dispatch per run in nz_graph_series_next.  The signature
   * (FNV-1a of the kernels) tells machine code made for another choice of
   * kernels (a select's other branch) from the one for this begin. */
  p->nsrun = 0;
  unsigned long sig = 0xcbf29ce484222325UL;
  for (int i = 0; i < p->nrec; i++) {
    if (p->nsrun == 0 || p->sruns[p->nsrun - 1].op != p->srecs[i].op)
      p->sruns[p->nsrun++].op = p->srecs[i].op;
    p->sruns[p->nsrun - 1].end = i + 1;
    p->ser_v[i] = p->srecs[i].v;
    sig = (sig ^ (unsigned long)p->srecs[i].op) * 0x100000001b3UL;
  }
  p->ser_sig = sig | 1;   /* never 0 */
  p->ser_k = 0;
  return NZ_OK;
}

/* Machine code applies: attached, made for the kernels of the last
 * interpreted begin, and that begin's kernels (and their pointers into
 * the storage) still stand.  Only for series of order >= 1: with order 0
 * a begin may choose other kernels (x^p at x = 0 is then a constant). */
static int series_code_ok(const nz_graph_plan *p)
{
  return p->ser_code && p->ser_code_sig == p->ser_sig && p->ser_K >= 1;
}

nz_status nz_graph_series_begin(nz_graph_plan *p, int max_order, const double *in0)
{
  nz_status st;
  p->fail_node = -1;
  p->ser_k = -1;
  p->ser_ties = 0;
  if (max_order < 0 || max_order > NZ_JET_MAX_ORDER) return NZ_EDOM;
  if (p->bad_const >= 0)
    return nz_graph_plan_fail(p, p->bad_const, d_finite(p->vals[p->bad_const]), p->vals[p->bad_const]);
  const double *old = p->ser;
  if ((st = series_storage(p, max_order))) return st;
  if (p->ser != old) p->ser_sig = 0;   /* the kernels point into the old storage */
  p->ser_K = max_order;
  if ((st = series_inputs(p, in0, 0))) return st;
  for (int s = p->nin; s < p->base; s++) {   /* constants: exact to every order */
    double *c = series_of(p, s);
    c[0] = p->vals[s];
    for (int k = 1; k <= max_order; k++) c[k] = 0.0;
  }
  /* Machine code makes coefficient 0 with the same checks (series_native.c);
   * on a refusal the interpreter begins again and says why. */
  if (series_code_ok(p) && p->ser_code(0, p->ser_cap + 1, p->ser, p->ser_v, p->ser_kfn) == 0) {
    p->ser_k = 0;
    return NZ_OK;
  }
  return series_first_all(p, max_order);
}

/* Coefficient k of every computed slot by the interpreter, the inputs'
 * coefficient k in place. */
static nz_status series_next_interp(nz_graph_plan *p, int k)
{
  int K = p->ser_cap, i = 0;
  const srec *R = p->srecs;
  /* One dispatch per run; series_coef is inlined with a constant kernel. */
#define RUN(OP) case OP: for (; i < e; i++) series_coef(&R[i], OP, k, K); break;
  for (int q = 0; q < p->nsrun; q++) {
    int e = p->sruns[q].end;
    switch (p->sruns[q].op) {
      RUN(NZ_SK_ADD) RUN(NZ_SK_SUB) RUN(NZ_SK_MUL) RUN(NZ_SK_SCALE) RUN(NZ_SK_DIV) RUN(NZ_SK_DIVC) RUN(NZ_SK_SQR)
      RUN(NZ_SK_POWI) RUN(NZ_SK_POWR) RUN(NZ_SK_POW) RUN(NZ_SK_EXP) RUN(NZ_SK_LOG) RUN(NZ_SK_SQRT) RUN(NZ_SK_SIN)
      RUN(NZ_SK_COS) RUN(NZ_SK_SINH) RUN(NZ_SK_COSH) RUN(NZ_SK_TAN) RUN(NZ_SK_TANH) RUN(NZ_SK_ATAN) RUN(NZ_SK_ASIN)
      RUN(NZ_SK_ACOS) RUN(NZ_SK_ATAN2) RUN(NZ_SK_HYPOT) RUN(NZ_SK_STEP) RUN(NZ_SK_COPY)
    default: for (; i < e; i++) R[i].z[k] = NAN; break;
    }
  }
#undef RUN
  /* The first non-finite coefficient in slot order: where it appeared (a
   * NaN or an infinity flows into the later nodes). */
  for (i = 0; i < p->nrec; i++)
    if (!isfinite(R[i].z[k]))
      return nz_graph_plan_fail(p, p->base + i, d_finite(R[i].z[k]), series_of(p, p->jrecs[i].a)[0]);
  p->ser_k = k;
  return NZ_OK;
}

nz_status nz_graph_series_next(nz_graph_plan *p, int k, const double *in_k, double *out_k)
{
  nz_status st;
  p->fail_node = -1;
  if (p->ser_k < 0 || k < 1 || k > p->ser_k + 1 || k > p->ser_K) return NZ_EDOM;
  p->ser_k = k - 1;   /* coefficient k, if it was filled, is being replaced */
  if (in_k && (st = series_inputs(p, in_k, k))) return st;
  if (series_code_ok(p)) {
    /* Machine code for these kernels: when every coefficient it made is
     * finite, they are the interpreter's.  Otherwise the interpreter
     * begins again from the inputs in place and redoes coefficients 1..k
     * (its begin may have been the machine code's), to name the node. */
    if (p->ser_code(k, p->ser_cap + 1, p->ser, p->ser_v, p->ser_kfn) == 0) {
      p->ser_k = k;
      goto done;
    }
    if ((st = series_first_all(p, p->ser_K))) return st;
    for (int j = 1; j < k; j++)
      if ((st = series_next_interp(p, j))) return st;
  }
  if ((st = series_next_interp(p, k))) return st;
done:
  if (out_k)
    for (int o = 0; o < p->nout; o++) out_k[o] = series_of(p, p->out_slot[o])[k];
  return NZ_OK;
}

int nz_graph_series_order(const nz_graph_plan *p) { return p->ser_k; }

int nz_graph_series_ties(const nz_graph_plan *p) { return p->ser_ties; }

double nz_graph_series_coef(const nz_graph_plan *p, int r, int j)
{
  if (r < 0 || r >= p->nout || j < 0 || j > p->ser_k) return NAN;
  return series_of(p, p->out_slot[r])[j];
}

const double *nz_graph_series_node(const nz_graph_plan *p, int node)
{
  if (p->ser_k < 0 || node < 0 || node > p->ser_top) return NULL;
  int s = p->ser_map[node];
  return s < 0 ? NULL : series_of(p, s);
}

int nz_graph_series_layout(const nz_graph_plan *p, nz_series_slot *slots, int *nseries)
{
  if (p->ser_k < 0 || !p->srecs) return -1;
  size_t L = (size_t)p->ser_cap + 1;
  *nseries = p->m + p->ser_naux;
  if (slots)
    for (int i = 0; i < p->nrec; i++) {
      const srec *r = &p->srecs[i];
      const jrec *jr = &p->jrecs[i];
      slots[i] = (nz_series_slot){
        .kernel = r->op, .gop = jr->op, .fn = jr->fn,
        .z = (int)((size_t)(r->z - p->ser) / L), .a = (int)((size_t)(r->a - p->ser) / L),
        .b = (int)((size_t)(r->b - p->ser) / L),
        .aux = p->m + p->ser_aux[i],
        .n = r->n, .v = r->v };
    }
  return p->nrec;
}

unsigned long nz_graph_series_signature(const nz_graph_plan *p) { return p->ser_k < 0 ? 0 : p->ser_sig; }

void nz_graph_series_use(nz_graph_plan *p, nz_series_code code, void (*const *K)(void), unsigned long sig)
{
  p->ser_code = code;
  p->ser_kfn = K;
  p->ser_code_sig = code ? sig : 0;
}

int nz_graph_series_input_slots(const nz_graph_plan *p, int *in_num)
{
  if (p->ser_k < 0) return -1;
  if (in_num)
    for (int s = 0; s < p->nin; s++) in_num[s] = p->in_num[s];
  return p->nin;
}

int nz_graph_series_output(const nz_graph_plan *p, int r) { return r >= 0 && r < p->nout ? p->out_slot[r] : -1; }

int nz_graph_series_loop(nz_graph_plan *p, nz_series_loop loop, void (*const *K)(void), unsigned long sig, int N,
                         double *a)
{
  if (p->ser_k < 0 || N < 0 || N > p->ser_K || sig != p->ser_sig || p->ser_K < 1) return -1;
  p->fail_node = -1;
  int rc = loop(N, p->ser_cap + 1, p->ser, p->ser_v, K, a);
  p->ser_k = rc ? 0 : N;   /* refused: coefficient 0 (begin's) still stands */
  return rc;
}

