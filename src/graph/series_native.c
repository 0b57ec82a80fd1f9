/* series_native.c - C generated for the series of a plan, coefficient k
 * of every computed slot (see series_native.h).
 *
 * The generated function nzs_next(k, L, S, v, K) runs the computed slots
 * in the plan's order.  Series s is S + s L (graph_series.h); each slot's
 * kernel is written out for k >= 1 (coefficient 0 is begin's, in the
 * interpreter): sums and scalings as one line, the Cauchy products and the
 * recurrences of exp, log, sqrt, sin/cos and tan as small inline functions
 * that are series.c's, expression for expression (compiled with
 * -ffp-contract=off and without -ffast-math, so they round alike); x^n,
 * x^p, the quadratures (atan, asin, acos) and atan2 call series.c's kernels
 * themselves through the table K (function pointers the caller passes, so
 * the object needs no symbol of nzlua).
 *
 * Each coefficient made by a slot that no other slot reads is added, times
 * 0.0, into one of four sums: the sum is 0 when all are finite and NaN
 * otherwise, and the function returns nonzero then (the interpreter redoes
 * the work and names the node).  A failure anywhere reaches those slots
 * (see generate: every kernel is strict).
 *
 * Big plans are cut into functions of CHUNK slots (a compiler slows down
 * superlinearly on one huge function); all values live in S, so the parts
 * share nothing else. */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "graph/graph_series.h"
#include "graph/native_object.h"
#include "graph/series_gen.h"
#include "graph/series_native.h"
#include "jets/series.h"

#define SER_VERSION "nzlua-series 13"
#ifndef CHUNK
#define CHUNK 2000
#endif
#define INLINE_SLOTS 60
/* Orders of a small plan's second-order ODE written out (the order of
 * Taylor's method for a tolerance of 1e-16 is 20). */
#define ODE2_UNROLLED NZ_SERIES_MIN_ORDER

static void (*const kernel_table[K_COUNT])(void) = {
  [K_POWI] = (void (*)(void))nz_series_powi_coef,
  [K_POW] = (void (*)(void))nz_series_pow_coef,
  [K_QUAD] = (void (*)(void))nz_series_quadrature_coef,
  [K_ATAN2] = (void (*)(void))nz_series_atan2_coef,
};

struct nz_series_native {
  nz_native_object obj;
  nz_ctab tab;           /* compact code's tables, until the object is loaded */
  int compact;
  nz_series_code code;   /* NULL while it compiles */
  nz_series_loop ode2;   /* NULL: made without a second-order ODE */
  int ode2_wanted;
  unsigned long sig;
  int slots;
};

/* The loaded object's functions. */
static int entries(nz_series_native *s, char *why, size_t whylen)
{
  if (s->compact && nz_ctab_fill(s->obj.dl, &s->tab, why, whylen)) return -1;
  nz_ctab_free(&s->tab);
  /* POSIX: a data pointer from dlsym converts to a function pointer. */
  memcpy(&s->code, &s->obj.entry, sizeof s->code);
  if (s->ode2_wanted) {
    void *e = dlsym(s->obj.dl, "nzs_ode2");
    if (!e) {
      nz_native_say(why, whylen, "'%s' has no nzs_ode2", s->obj.path);
      s->code = NULL;
      return -1;
    }
    memcpy(&s->ode2, &e, sizeof s->ode2);
  }
  return 0;
}

/* series.c's recurrences, written the same way. */
static const char preamble[] =
  "#include <math.h>\n#include <stddef.h>\n"
  "#if defined(__GNUC__)\n#define NZS_NOINLINE __attribute__((noinline))\n"
  "#else\n#define NZS_NOINLINE\n#endif\n"
  "#ifndef NZS_KERNEL\n#define NZS_KERNEL NZS_NOINLINE\n#endif\n"
  "typedef double (*nzs_powi_f)(double *, const double *, unsigned, int, int);\n"
  "typedef double (*nzs_pow_f)(const double *, const double *, double, int);\n"
  "typedef double (*nzs_quad_f)(const double *, const double *, const double *, double, int);\n"
  "typedef double (*nzs_atan2_f)(const double *, const double *, const double *, const double *, int);\n"
  "static NZS_KERNEL double nzs_mul(const double *a, const double *b, int k)\n"
  "{\n  double s = 0.0;\n  if (a == b) {\n"
  "    for (int j = 0; 2 * j < k; j++) s += a[j] * a[k - j];\n"
  "    s += s;\n    if (!(k & 1)) s += a[k / 2] * a[k / 2];\n    return s;\n  }\n"
  "  s = a[0] * b[k];\n  for (int j = 1; j <= k; j++) s += a[j] * b[k - j];\n  return s;\n}\n"
  "static NZS_KERNEL double nzs_div(const double *z, const double *a, const double *b, int k)\n"
  "{ double s = a[k]; for (int j = 0; j < k; j++) s -= z[j] * b[k - j]; return s / b[0]; }\n"
  "static NZS_KERNEL double nzs_exp(const double *y, const double *x, int k)\n"
  "{\n  if (k == 0) return exp(x[0]);\n"
  "  double s = 0.0; for (int j = 1; j <= k; j++) s += j * x[j] * y[k - j]; return s / k;\n}\n"
  "static NZS_KERNEL double nzs_log(const double *y, const double *x, int k)\n"
  "{\n  if (k == 0) return log(x[0]);\n"
  "  double s = 0.0; for (int j = 1; j < k; j++) s += j * y[j] * x[k - j]; return (x[k] - s / k) / x[0];\n}\n"
  "static NZS_KERNEL double nzs_sqrt(const double *y, const double *x, int k)\n"
  "{\n  if (k == 0) return sqrt(x[0]);\n"
  "  double s = 0.0; for (int j = 1; j < k; j++) s += y[j] * y[k - j]; return (x[k] - s) / (2.0 * y[0]);\n}\n"
  "static NZS_KERNEL void nzs_sincos(double *s, double *c, const double *x, int k, int hyperbolic)\n"
  "{\n  if (k == 0) {\n"
  "    s[0] = hyperbolic ? sinh(x[0]) : sin(x[0]);\n    c[0] = hyperbolic ? cosh(x[0]) : cos(x[0]);\n"
  "    return;\n  }\n"
  "  double ss = 0.0, cc = 0.0;\n"
  "  for (int j = 1; j <= k; j++) { ss += j * x[j] * c[k - j]; cc += j * x[j] * s[k - j]; }\n"
  "  s[k] = ss / k;\n  c[k] = (hyperbolic ? cc : -cc) / k;\n}\n"
  "static NZS_KERNEL void nzs_tan(double *t, double *u, const double *x, int k, int hyperbolic)\n"
  "{\n  double sign = hyperbolic ? -1.0 : 1.0;\n"
  "  if (k == 0) {\n    t[0] = hyperbolic ? tanh(x[0]) : tan(x[0]);\n    u[0] = 1.0 + sign * t[0] * t[0];\n"
  "    return;\n  }\n"
  "  double s = 0.0;\n  for (int j = 1; j <= k; j++) s += j * x[j] * u[k - j];\n"
  "  t[k] = s / k;\n  u[k] = sign * nzs_mul(t, t, k);\n}\n"
  "#define SER(i) (S + (size_t)(i) * l)\n";

/* Branches choose their kernel from the state at each begin. */
static int branch(const nz_series_slot *r)
{
  return r->gop == NZ_GOP_CMP || r->gop == NZ_GOP_SELECT ||
         (r->gop == NZ_GOP_FN && (r->fn == NZ_FN_SIGN || r->fn == NZ_FN_ABS));
}

/* nzs_mul(SER(a), SER(b), kc) written out for a known kc: the same sums
 * in the same order, without a loop whose trip count changes at every call
 * (its exit was the costliest branch of a small plan). */
static void emit_product(nz_sbuf *b, int z, int a, int bb, int kc)
{
  nz_sb_printf(b, "  { double s = 0.0;");
  if (a == bb) {
    for (int j = 0; 2 * j < kc; j++) nz_sb_printf(b, " s += SER(%d)[%d] * SER(%d)[%d];", a, j, a, kc - j);
    nz_sb_printf(b, " s += s;");
    if (!(kc & 1)) nz_sb_printf(b, " s += SER(%d)[%d] * SER(%d)[%d];", a, kc / 2, a, kc / 2);
  } else {
    nz_sb_printf(b, " s = SER(%d)[0] * SER(%d)[%d];", a, bb, kc);
    for (int j = 1; j <= kc; j++) nz_sb_printf(b, " s += SER(%d)[%d] * SER(%d)[%d];", a, j, bb, kc - j);
  }
  nz_sb_printf(b, " SER(%d)[%d] = s; }\n", z, kc);
}

void nz_series_emit_kernel(nz_sbuf *b, int kernel, const nz_series_ref *r)
{
  const char *z = r->z, *a = r->a, *bb = r->b, *v = r->v, *vi = r->vi;
  const char *const *w = r->w;
  switch (kernel) {
  case NZ_SK_ADD: nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k] + SER(%s)[k];\n", z, a, bb); break;
  case NZ_SK_SUB: nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k] - SER(%s)[k];\n", z, a, bb); break;
  case NZ_SK_MUL: nz_sb_printf(b, "  SER(%s)[k] = nzs_mul(SER(%s), SER(%s), k);\n", z, a, bb); break;
  case NZ_SK_SQR: nz_sb_printf(b, "  SER(%s)[k] = nzs_mul(SER(%s), SER(%s), k);\n", z, a, a); break;
  case NZ_SK_SCALE: nz_sb_printf(b, "  SER(%s)[k] = %s * SER(%s)[k];\n", z, v, a); break;
  case NZ_SK_DIV: nz_sb_printf(b, "  SER(%s)[k] = nzs_div(SER(%s), SER(%s), SER(%s), k);\n", z, z, a, bb); break;
  case NZ_SK_DIVC: nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k] / %s;\n", z, a, v); break;
  case NZ_SK_POWI:
    nz_sb_printf(b, "  SER(%s)[k] = ((nzs_powi_f)K[%d])(SER(%s), SER(%s), %uu, k, L - 1);\n", z, K_POWI, w[0], a, r->n);
    break;
  case NZ_SK_POWR:
    nz_sb_printf(b, "  if (k == 0) bad |= SER(%s)[0] == 0.0;\n", a);
    nz_sb_printf(b, "  SER(%s)[k] = ((nzs_pow_f)K[%d])(SER(%s), SER(%s), %s, k);\n", z, K_POW, z, a, v);
    break;
  case NZ_SK_POW:   /* exp(y log x) */
    nz_sb_printf(b, "  SER(%s)[k] = nzs_log(SER(%s), SER(%s), k);\n", w[0], w[0], a);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_mul(SER(%s), SER(%s), k);\n", w[1], bb, w[0]);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_exp(SER(%s), SER(%s), k);\n", z, z, w[1]);
    break;
  case NZ_SK_EXP: nz_sb_printf(b, "  SER(%s)[k] = nzs_exp(SER(%s), SER(%s), k);\n", z, z, a); break;
  case NZ_SK_LOG: nz_sb_printf(b, "  SER(%s)[k] = nzs_log(SER(%s), SER(%s), k);\n", z, z, a); break;
  case NZ_SK_SQRT:
    nz_sb_printf(b, "  if (k == 0) bad |= SER(%s)[0] == 0.0;\n", a);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_sqrt(SER(%s), SER(%s), k);\n", z, z, a);
    break;
  case NZ_SK_SIN: case NZ_SK_SINH:
    nz_sb_printf(b, "  nzs_sincos(SER(%s), SER(%s), SER(%s), k, %d);\n", z, w[0], a, kernel == NZ_SK_SINH);
    break;
  case NZ_SK_COS: case NZ_SK_COSH:
    nz_sb_printf(b, "  nzs_sincos(SER(%s), SER(%s), SER(%s), k, %d);\n", w[0], z, a, kernel == NZ_SK_COSH);
    break;
  case NZ_SK_TAN: case NZ_SK_TANH:
    nz_sb_printf(b, "  nzs_tan(SER(%s), SER(%s), SER(%s), k, %d);\n", z, w[0], a, kernel == NZ_SK_TANH);
    break;
  case NZ_SK_ATAN:   /* y' (1 + x^2) = x' */
    nz_sb_printf(b, "  SER(%s)[k] = nzs_mul(SER(%s), SER(%s), k);\n", w[0], a, a);
    nz_sb_printf(b, "  if (k == 0) { SER(%s)[0] += 1.0; SER(%s)[0] = atan(SER(%s)[0]); }\n", w[0], z, a);
    nz_sb_printf(b, "  else SER(%s)[k] = ((nzs_quad_f)K[%d])(SER(%s), SER(%s), SER(%s), 1.0, k);\n", z, K_QUAD, z,
                 a, w[0]);
    break;
  case NZ_SK_ASIN: case NZ_SK_ACOS:   /* y' sqrt(1 - x^2) = +-x' */
    nz_sb_printf(b, "  SER(%s)[k] = -nzs_mul(SER(%s), SER(%s), k);\n", w[0], a, a);
    nz_sb_printf(b, "  if (k == 0) { SER(%s)[0] += 1.0; bad |= fabs(SER(%s)[0]) == 1.0; }\n", w[0], a);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_sqrt(SER(%s), SER(%s), k);\n", w[1], w[1], w[0]);
    nz_sb_printf(b, "  if (k == 0) SER(%s)[0] = %s(SER(%s)[0]);\n", z, kernel == NZ_SK_ASIN ? "asin" : "acos", a);
    nz_sb_printf(b, "  else SER(%s)[k] = ((nzs_quad_f)K[%d])(SER(%s), SER(%s), SER(%s), %s, k);\n", z, K_QUAD, z,
                 a, w[1], kernel == NZ_SK_ASIN ? "1.0" : "-1.0");
    break;
  case NZ_SK_ATAN2:
    nz_sb_printf(b, "  if (k == 0) bad |= SER(%s)[0] == 0.0 && SER(%s)[0] == 0.0;\n", a, bb);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_mul(SER(%s), SER(%s), k) + nzs_mul(SER(%s), SER(%s), k);\n", w[0], bb, bb, a,
                 a);
    nz_sb_printf(b, "  SER(%s)[k] = ((nzs_atan2_f)K[%d])(SER(%s), SER(%s), SER(%s), SER(%s), k);\n", z, K_ATAN2, z,
                 a, bb, w[0]);
    break;
  case NZ_SK_HYPOT:   /* s sqrt((a/s)^2 + (b/s)^2), s = max(|a_0|, |b_0|) = v[i] */
    nz_sb_printf(b, "  if (k == 0) { %s = fmax(fabs(SER(%s)[0]), fabs(SER(%s)[0])); bad |= %s == 0.0; }\n", vi, a,
                 bb, vi);
    nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k] / %s;\n", w[0], a, vi);
    nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k] / %s;\n", w[1], bb, vi);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_mul(SER(%s), SER(%s), k) + nzs_mul(SER(%s), SER(%s), k);\n", w[2], w[0],
                 w[0], w[1], w[1]);
    nz_sb_printf(b, "  SER(%s)[k] = nzs_sqrt(SER(%s), SER(%s), k);\n", w[3], w[3], w[2]);
    nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k] * %s;\n", z, w[3], vi);
    break;
  case NZ_SK_STEP: nz_sb_printf(b, "  SER(%s)[k] = k == 0 ? 1.0 : 0.0;   /* x^0 */\n", z); break;
  case NZ_SK_COPY: nz_sb_printf(b, "  SER(%s)[k] = SER(%s)[k];\n", z, a); break;
  default: nz_sb_printf(b, "  SER(%s)[k] = NAN;\n", z); break;
  }
}

/* Slot i's kernel at coefficient k, as graph_series.c's series_coef; at k = 0
 * also the domain checks of its series_first for an order >= 1 that a
 * finite coefficient 0 would not reveal (the others give an infinity or a
 * NaN: log 0, 1/0, sqrt(-1), ...), into `bad`.  kc >= 0: the code for
 * that coefficient only (k a constant in scope), products written out. */
static void emit_slot(nz_sbuf *b, const nz_series_slot *r, int i, int check, int kc)
{
  if (kc >= 0 && (r->kernel == NZ_SK_MUL || r->kernel == NZ_SK_SQR))
    emit_product(b, r->z, r->a, r->kernel == NZ_SK_SQR ? r->a : r->b, kc);
  else {
    char z[16], a[16], bb[16], w[4][16], v[64], vi[32];
    const char *wp[4] = { w[0], w[1], w[2], w[3] };
    snprintf(z, sizeof z, "%d", r->z);
    snprintf(a, sizeof a, "%d", r->a);
    snprintf(bb, sizeof bb, "%d", r->b);
    for (int j = 0; j < 4; j++) snprintf(w[j], sizeof w[j], "%d", r->aux + j);
    nz_native_literal(v, sizeof v, r->v);
    snprintf(vi, sizeof vi, "v[%d]", i);
    nz_series_ref ref = { z, a, bb, { wp[0], wp[1], wp[2], wp[3] }, v, vi, r->n };
    nz_series_emit_kernel(b, r->kernel, &ref);
  }
  if (check) nz_sb_printf(b, "  c%d += SER(%d)[k] * 0.0;\n", i & 3, r->z);
}

/* The inputs of coefficient n (a C expression) of a second-order ODE, with
 * the very expressions of nz_recording_motion_series (mech_graph_series.c) so that
 * the numbers are the same: q_i from a[n], q_i' from a[n + 1], t, the rest
 * constant. */
static void emit_ode2_inputs(nz_sbuf *b, const nz_graph_plan *p, const nz_series_ode2 *o, const int *in_num, int nin,
                             const char *n)
{
  for (int s = 0; s < nin; s++) {
    int role = 0, i = 0;   /* 1 q_i, 2 q_i', 3 t, 0 constant */
    for (int j = 0; j < o->k && !role; j++) {
      if (in_num[s] == o->pos[j]) role = 1, i = j;
      else if (in_num[s] == o->vel[j]) role = 2, i = j;
    }
    if (!role && in_num[s] == o->time) role = 3;
    if (role == 1) nz_sb_printf(b, "    SER(%d)[%s] = a[(size_t)(%s) * %d + %d];\n", s, n, n, o->k, i);
    else if (role == 2) nz_sb_printf(b, "    SER(%d)[%s] = ((%s) + 1) * a[(size_t)((%s) + 1) * %d + %d];\n", s, n, n, n, o->k, i);
    else if (role == 3) nz_sb_printf(b, "    SER(%d)[%s] = (%s) == 1 ? 1.0 : 0.0;\n", s, n, n);
    else nz_sb_printf(b, "    SER(%d)[%s] = 0.0;\n", s, n);
  }
  (void)p;
}

/* a[n + 2] from the outputs of coefficient n, as nz_series_ode2_coef
 * (series.h) gives it: the division or the product by the reciprocal
 * written out for an order known here, chosen in the loop. */
static void emit_ode2_outputs(nz_sbuf *b, const nz_graph_plan *p, const nz_series_ode2 *o, const char *n)
{
  int known = n[0] >= '0' && n[0] <= '9';
  nz_sb_printf(b, "    { const double m_ = (double)((%s) + 1) * (double)((%s) + 2);\n", n, n);
  for (int i = 0; i < o->k; i++) {
    int x = nz_graph_series_output(p, o->acc[i]);
    nz_sb_printf(b, "      a[(size_t)((%s) + 2) * %d + %d] = ", n, o->k, i);
    if (!known) nz_sb_printf(b, "(%s) < %d ? SER(%d)[%s] / m_ : SER(%d)[%s] * (1.0 / m_);\n", n, NZ_SERIES_ODE2_DIVIDED, x,
                             n, x, n);
    else if (atoi(n) < NZ_SERIES_ODE2_DIVIDED) nz_sb_printf(b, "SER(%d)[%s] / m_;\n", x, n);
    else nz_sb_printf(b, "SER(%d)[%s] * (1.0 / m_);\n", x, n);
  }
  nz_sb_printf(b, "    }\n");
}

/* The fused loop of a second-order ODE (series_native.h).  A small plan
 * (one part) gets it written out order by order up to ODE2_UNROLLED, every
 * product a straight sum (emit_product): no branch whose outcome changes
 * from one order to the next; a failure is looked for once at the end (a
 * NaN only spoils later coefficients, and the caller then redoes all).
 * Beyond that order, and for big plans, a loop over the parts. */
static void emit_ode2(nz_sbuf *b, const nz_graph_plan *p, const nz_series_ode2 *o, int nparts, int straight,
                      const nz_series_slot *slots, int n, const char *used)
{
  int nin = nz_graph_series_input_slots(p, NULL), *in_num = malloc(((size_t)nin + 1) * sizeof *in_num);
  if (!in_num) { b->oom = 1; return; }
  nz_graph_series_input_slots(p, in_num);
  nz_sb_printf(b, "\nint nzs_ode2(int N, int L, double *restrict S, double *restrict v, void (*const *K)(void), "
                  "double *restrict a);\n"
                  "int nzs_ode2(int N, int L, double *restrict S, double *restrict v, void (*const *K)(void), "
                  "double *restrict a)\n{\n  const size_t l = (size_t)L;\n  (void)v; (void)K;\n");
  if (straight && nparts == 1 && n <= INLINE_SLOTS) {
    /* the arena's stride as a constant (graph_series.h): every address a
     * constant offset from S, none computed or kept in a register */
    nz_sb_printf(b, "  if (N > %d || L != %d) goto loop;\n  {\n  const size_t l = %d;\n"
                    "  double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;\n  int bad = 0;\n",
                 ODE2_UNROLLED, ODE2_UNROLLED + 1, ODE2_UNROLLED + 1);
    emit_ode2_outputs(b, p, o, "0");
    for (int kc = 1; kc <= ODE2_UNROLLED; kc++) {
      char ks[16];
      snprintf(ks, sizeof ks, "%d", kc);
      nz_sb_printf(b, "  if (N < %d) goto done;\n  {\n  const int k = %d;\n", kc, kc);
      emit_ode2_inputs(b, p, o, in_num, nin, ks);
      for (int i = 0; i < n; i++) emit_slot(b, &slots[i], i, !used[slots[i].z], kc);
      emit_ode2_outputs(b, p, o, ks);
      nz_sb_printf(b, "  }\n");
    }
    nz_sb_printf(b, "done:\n  return bad || !((c0 + c1) + (c2 + c3) == 0.0);\n  }\nloop:;\n");
  }
  nz_sb_printf(b, "  for (int n = 0; n <= N; n++) {\n    if (n > 0) {\n");
  emit_ode2_inputs(b, p, o, in_num, nin, "n");
  nz_sb_printf(b, "      double c = 0.0;\n");
  for (int c = 0; c < nparts; c++) nz_sb_printf(b, "      c += nzs_part%d(n, L, S, v, K);\n", c);
  nz_sb_printf(b, "      if (!(c == 0.0)) return n + 1;\n    }\n");
  emit_ode2_outputs(b, p, o, "n");
  nz_sb_printf(b, "  }\n  return 0;\n}\n");
  free(in_num);
}

/* The source: straight-line code, or compact code (series_compact.c)
 * when compact is set, its tables into *tab. */
static char *generate(const nz_graph_plan *p, const nz_series_ode2 *ode2, const nz_series_slot *slots, int n,
                      int nseries, int compact, nz_ctab *tab, char *why, size_t whylen)
{
  nz_sbuf b = { 0 };
  int nparts = (n + CHUNK - 1) / CHUNK;
  /* Which coefficients to test.  Every kernel is strict at the level of
   * one coefficient: its operands' coefficient k enters with a factor (a
   * Cauchy term, x_k z_0, ...), and in IEEE arithmetic inf * 0 is NaN and a
   * NaN or an infinity makes every sum and product that holds it non-finite.
   * So a slot read by another slot (other than x^0's, which reads nothing)
   * passes its failure on, and only the slots nothing reads are tested. */
  char *used = calloc((size_t)nseries + 1, 1);
  if (!used) {
    nz_native_say(why, whylen, "out of memory generating C for %d slots", n);
    return NULL;
  }
  for (int i = 0; i < n; i++)
    if (slots[i].kernel != NZ_SK_STEP) used[slots[i].a] = used[slots[i].b] = 1;
  /* The kernels inlined into a small plan (3 % faster on Henon-Heiles);
   * called in a big one, which then compiles 7x faster (measured on a
   * random plan of 300 nodes: 0.7 s against 5 s). */
  nz_sb_printf(&b, "/* Generated by nzlua (%s): coefficient k of %d computed slots, %d series, %s code. */\n%s%s",
               SER_VERSION, n, nseries, compact ? "compact" : "straight-line",
               n <= INLINE_SLOTS ? "#define NZS_KERNEL inline\n" : "", preamble);
  /* one small part is inlined into the loop of ode2 */
  nz_sb_printf(&b, "#define NZS_PART %s\n", !compact && nparts == 1 && n <= INLINE_SLOTS ? "inline" : "NZS_NOINLINE");
  if (compact) nparts = nz_series_emit_compact(&b, slots, n, nseries, used, tab);
  for (int c = 0; !compact && c < nparts; c++) {
    nz_sb_printf(&b, "\nstatic NZS_PART double nzs_part%d(int k, int L, double *restrict S, "
                     "double *restrict v, void (*const *K)(void))\n{\n"
                     "  const size_t l = (size_t)L;\n  double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;\n"
                     "  int bad = 0;\n  (void)v; (void)K;\n", c);
    for (int i = c * CHUNK; i < n && i < (c + 1) * CHUNK; i++) emit_slot(&b, &slots[i], i, !used[slots[i].z], -1);
    nz_sb_printf(&b, "  return bad ? NAN : (c0 + c1) + (c2 + c3);\n}\n");
  }
  nz_sb_printf(&b, "\nint nzs_next(int k, int L, double *restrict S, double *restrict v, void (*const *K)(void));\n"
                   "int nzs_next(int k, int L, double *restrict S, double *restrict v, void (*const *K)(void))\n"
                   "{\n  double c = 0.0;\n");
  for (int c = 0; c < nparts; c++) nz_sb_printf(&b, "  c += nzs_part%d(k, L, S, v, K);\n", c);
  nz_sb_printf(&b, "  return !(c == 0.0);\n}\n");
  if (ode2) emit_ode2(&b, p, ode2, nparts, !compact, slots, n, used);
  free(used);
  if (b.oom) {
    free(b.s);
    nz_native_say(why, whylen, "out of memory generating C for %d slots", n);
    return NULL;
  }
  return b.s;
}

nz_series_native *nz_series_native_get(const nz_graph_plan *p, const nz_series_ode2 *ode2, const char *cache_dir,
                                       int how, char *why, size_t whylen)
{
  double t0 = nz_native_now();
  int nseries, n = nz_graph_series_layout(p, NULL, &nseries);
  if (why && whylen) why[0] = 0;
  if (n < 0 || !cache_dir) {
    nz_native_say(why, whylen, "nz_series_native_get: no series begun, or no cache directory");
    return NULL;
  }
  nz_series_slot *slots = malloc(((size_t)n + 1) * sizeof *slots);
  nz_series_native *s = calloc(1, sizeof *s);
  char *src = NULL;
  if (!slots || !s) {
    nz_native_say(why, whylen, "out of memory");
    goto fail;
  }
  nz_graph_series_layout(p, slots, &nseries);
  for (int i = 0; i < n; i++)
    if (branch(&slots[i])) {
      nz_native_say(why, whylen, "the series has a branch (%s%s%s): its kernels change with the state",
                    nz_gop_names[slots[i].gop], slots[i].gop == NZ_GOP_FN ? " " : "",
                    slots[i].gop == NZ_GOP_FN ? nz_jet_fn_names[slots[i].fn] : "");
      goto fail;
    }
  s->compact = nz_native_compact(n, NZ_SERIES_COMPACT_SLOTS);
  if (!(src = generate(p, ode2, slots, n, nseries, s->compact, &s->tab, why, whylen))) goto fail;
  /* -O2 for a small plan: Henon-Heiles' series (written out to order 24)
   * runs 19 % faster than at -O1 (1.52 against 1.88 ms for t = 0..2000 at
   * 1e-15, NZLUA_COPT to compare), which pays for the compiler's extra
   * ~0.2 s within a few runs; -O1 above 60 slots, where -O2's time to
   * compile grows faster than what it saves */
  s->ode2_wanted = ode2 != NULL;
  int got = nz_native_object_get(src, SER_VERSION, "nzs", "nzs_next", !s->compact && n > INLINE_SLOTS, how, cache_dir, t0, &s->obj,
                                 why, whylen);
  if (got < 0 || (got == 0 && entries(s, why, whylen))) goto fail;
  s->sig = nz_graph_series_signature(p);
  s->slots = n;
  free(src);
  free(slots);
  return s;
fail:
  free(src);
  free(slots);
  nz_series_native_free(s);
  return NULL;
}

int nz_series_native_ready(nz_series_native *s, int wait, char *why, size_t whylen)
{
  if (s->code) return 0;
  int r = nz_native_object_ready(&s->obj, wait, why, whylen);
  if (r == 0 && entries(s, why, whylen)) return -1;
  return r;
}

void nz_series_native_attach(const nz_series_native *s, nz_graph_plan *p)
{
  nz_graph_series_use(p, s->code, kernel_table, s->sig);
}

int nz_series_native_ode2(const nz_series_native *s, nz_graph_plan *p, int N, double *a)
{
  if (!s->ode2) return -1;
  return nz_graph_series_loop(p, s->ode2, kernel_table, s->sig, N, a);
}

void nz_series_native_detach(nz_graph_plan *p) { nz_graph_series_use(p, NULL, NULL, 0); }

void nz_series_native_free(nz_series_native *s)
{
  if (!s) return;
  nz_native_object_close(&s->obj);
  nz_ctab_free(&s->tab);
  free(s);
}

double nz_series_native_seconds(const nz_series_native *s) { return s->obj.seconds; }
double nz_series_native_waited(const nz_series_native *s) { return s->obj.waited; }
int nz_series_native_slots(const nz_series_native *s) { return s->slots; }
int nz_series_native_compact_code(const nz_series_native *s) { return s->compact; }
const char *nz_series_native_path(const nz_series_native *s) { return s->obj.path; }
