/* mech_graph_series.c - the series of the motion from the recorded graphs
 * (Taylor's method): q'' order by order from the plan of M and h, free or
 * with constraints of any order (mech_graph.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "jets/series.h"
#include "mech/mech_graph_impl.h"

/* The workspace of nz_recording_motion_series for p + 1 coefficients. */
static int series_workspace(nz_recording *c, int p)
{
  if (p <= c->ts_cap) return NZ_OK;
  size_t k = (size_t)c->k, kk = k * k, n = (size_t)c->ninputs;
  size_t len = n + kk + nz_solve_spd_work_len(c->k) + k + (size_t)(p > 1 ? p - 1 : 1) * k;
  double *in = malloc(len * sizeof(double));
  const double **M = c->ts_M ? c->ts_M : malloc(kk * sizeof *M);
  double **inp = c->ts_inp ? c->ts_inp : malloc(n * sizeof *inp);
  int *pos = c->ts_pos ? c->ts_pos : malloc(3 * k * sizeof *pos);
  if (!in || !M || !inp || !pos) {
    free(in);
    if (!c->ts_M) free(M);
    if (!c->ts_inp) free(inp);
    if (!c->ts_pos) free(pos);
    return NZ_ENOMEM;
  }
  c->ts_inp = inp;
  c->ts_pos = pos;
  for (int i = 0; i < c->k; i++) {
    pos[i] = nz_recording_input_slot(c, 0, i);
    pos[k + (size_t)i] = nz_recording_input_slot(c, 1, i);
    pos[2 * k + (size_t)i] = i;
  }
  free(c->ts_in);
  c->ts_in = in;
  c->ts_M = M;
  c->ts_L = in + n;
  c->ts_work = c->ts_L + kk;
  c->ts_rhs = c->ts_work + nz_solve_spd_work_len(c->k);
  c->ts_qdd = c->ts_rhs + k;
  c->ts_cap = p;
  return NZ_OK;
}

/* Coefficient n of the inputs along the motion t0 + tau: t is t0 + tau
 * (1 at n = 1, then 0), a parameter is constant, slot 0 of q_i is a_n and
 * slot 1 is (n + 1) a_{n+1}; higher slots (unread by M and h) are 0. */
static void series_inputs_at(const nz_recording *c, double *in, int n, double t0, const double *a)
{
  int k = c->k;
  in[0] = n == 0 ? t0 : n == 1 ? 1.0 : 0.0;
  for (int p = 0; p < c->np; p++) in[1 + p] = n == 0 ? c->params[p] : 0.0;
  double *s0 = in + nz_recording_input_slot(c, 0, 0), *s1 = s0 + k;
  const double *an = a + (size_t)n * (size_t)k, *an1 = an + k;
  for (int i = 0; i < k; i++) {
    s0[i] = an[i];
    s1[i] = (n + 1) * an1[i];
  }
}

/* The same for n >= 1, written in place into the plan's input series
 * (nz_graph_series_inputs; NULL: an input the plan does not read). */
static void series_inputs_put(const nz_recording *c, double *const *ip, int n, const double *a)
{
  int k = c->k, s0 = nz_recording_input_slot(c, 0, 0);
  if (ip[0]) ip[0][n] = n == 1 ? 1.0 : 0.0;
  for (int x = 1; x < s0; x++)
    if (ip[x]) ip[x][n] = 0.0;
  for (int x = s0 + 2 * k; x < c->ninputs; x++)
    if (ip[x]) ip[x][n] = 0.0;
  const double *an = a + (size_t)n * (size_t)k, *an1 = an + k;
  for (int i = 0; i < k; i++) {
    if (ip[s0 + i]) ip[s0 + i][n] = an[i];
    if (ip[s0 + k + i]) ip[s0 + k + i][n] = (n + 1) * an1[i];
  }
}

int nz_recording_motion_series(nz_recording *c, double t0, const double *q0, const double *qd0, int p,
                              double *a)
{
  int k = c->k, st;
  if (p < 0 || p > NZ_JET_MAX_ORDER + 2) return NZ_EDOM;
  if (!nz_recording_mass_bias_ready(c)) return NZ_EARG;
  if ((st = series_workspace(c, p))) return st;
  memcpy(a, q0, (size_t)k * sizeof(double));
  if (p >= 1) memcpy(a + k, qd0, (size_t)k * sizeof(double));
  if (p < 2) return NZ_OK;
  /* q''s coefficients 0 .. N give a_2 .. a_p */
  int N = p - 2, constant = c->acc_plan != NULL;
  nz_graph_plan *plan = constant ? c->acc_plan->plan : c->mb_plan->plan;
  double *in = c->ts_in, *qdd = c->ts_qdd, *rhs = c->ts_rhs;
  memset(in, 0, (size_t)c->ninputs * sizeof(double));
  series_inputs_at(c, in, 0, t0, a);
  /* The plan's other outputs (F and V, evaluated to check that they are
   * defined) run along: a failure of any node is the jets' status, and
   * nz_recording_failure names it. */
  if ((st = nz_graph_series_begin(plan, N, in))) goto fail;
  if (constant) {
    /* q'' = -M^-1 h as a second-order ODE on the plan: its machine code
     * runs the whole series in one loop */
    nz_series_ode2 o = { k, 0, c->ts_pos, c->ts_pos + k, c->ts_pos + 2 * k };
    nz_dplan_series_native(c, c->acc_plan, N, &o);
    if (c->acc_plan->ser && nz_series_native_ode2(c->acc_plan->ser, plan, N, a) == 0) return NZ_OK;
  } else
    nz_dplan_series_native(c, c->mb_plan, N, NULL);
  /* the series of M's entries (of q'' itself with a constant M), filled
   * coefficient by coefficient below */
  const dplan *dp = constant ? c->acc_plan : c->mb_plan;
  for (int e = 0; e < (constant ? k : k * k); e++)
    if (!(c->ts_M[e] = nz_graph_series_node(plan, dp->outs[e]))) return NZ_EARG;
  nz_graph_series_inputs(plan, c->ts_inp, c->ninputs);
  for (int n = 0; n <= N; n++) {
    double *qn = qdd + (size_t)n * (size_t)k, *a2 = a + (size_t)(n + 2) * (size_t)k;
    if (n > 0) {
      series_inputs_put(c, c->ts_inp, n, a);
      if ((st = nz_graph_series_next(plan, n, NULL, NULL))) goto fail;
    }
    if (constant) {
      /* q'' = -M^-1 h is the plan: its coefficient n is the answer */
      for (int i = 0; i < k; i++) qn[i] = c->ts_M[i][n];
    } else {
      /* coefficient n of M q'' + h = 0: M_0 q''_n = -(h_n + sum_{m=1..n} M_m q''_{n-m}),
       * M_0 factored once (its condition checked) and its factor reused */
      for (int i = 0; i < k; i++) {
        double s = nz_graph_series_coef(plan, k * k + i, n);   /* h_i */
        for (int m = 1; m <= n; m++) {
          const double *qm = qdd + (size_t)(n - m) * (size_t)k;
          for (int j = 0; j < k; j++) s += c->ts_M[i * k + j][m] * qm[j];
        }
        rhs[i] = -s;
      }
      if (n == 0) {
        for (int e = 0; e < k * k; e++) c->ts_L[e] = c->ts_M[e][0];
        nz_solve_info info;
        st = nz_solve_spd_in(k, c->ts_L, rhs, qn, NZ_RCOND_MIN, &info, c->ts_work);
        if (st) {
          snprintf(c->failure, sizeof c->failure, "the mass matrix is %s (rcond %.3g)",
                   info.not_spd ? "not positive definite" : "singular", info.rcond);
          return st;
        }
      } else {
        memcpy(qn, rhs, (size_t)k * sizeof(double));
        nz_cholesky_solve(k, c->ts_L, qn);
      }
    }
    /* q''(t0 + tau) = sum (j + 1)(j + 2) a_{j+2} tau^j */
    for (int i = 0; i < k; i++) {
      if (!isfinite(qn[i])) {
        snprintf(c->failure, sizeof c->failure, "coefficient %d of q''_%d is not finite", n, i + 1);
        return isnan(qn[i]) ? NZ_ENAN : NZ_ERANGE;
      }
      a2[i] = nz_series_ode2_coef(qn[i], n);
    }
  }
  return NZ_OK;
fail:
  nz_recording_describe_failure(c, plan, st);
  return st;
}

int nz_recording_motion_branches(nz_recording *c)
{
  if (!nz_recording_mass_bias_ready(c)) return -1;
  const dplan *d = c->acc_plan ? c->acc_plan : c->mb_plan;
  int root = -1;
  for (int o = 0; o < d->nout; o++)
    if (d->outs[o] > root) root = d->outs[o];
  if (root < 0) return 0;
  const nz_gnode *nd = nz_graph_nodes(c->g);
  char *need = calloc((size_t)root + 1, 1);
  if (!need) return -1;
  for (int o = 0; o < d->nout; o++) need[d->outs[o]] = 1;
  /* folding removed the branches on constants: what is left switches with
   * the state (select's condition is a cmp, counted as such) */
  int n = 0;
  for (int x = root; x >= 0; x--) {
    if (!need[x]) continue;
    const nz_gnode *g = &nd[x];
    if (g->op == NZ_GOP_CONST || g->op == NZ_GOP_INPUT) continue;
    n += g->op == NZ_GOP_CMP || g->op == NZ_GOP_SELECT ||
         (g->op == NZ_GOP_FN && (g->fn == NZ_FN_SIGN || g->fn == NZ_FN_ABS));
    if (g->a >= 0) need[g->a] = 1;
    if (g->b >= 0) need[g->b] = 1;
    if (g->c >= 0) need[g->c] = 1;
  }
  free(need);
  return n;
}

/* ------------------------------------------------------------------ */
/* The series of a constrained motion (Taylor's method with constraints) */

/* Per constraint r of order m (m <= 2): a plan of Phi_r and of A_r =
 * dPhi_r/dq^(m) (k outputs), evaluated as series along the motion; and the
 * workspace of a step, grown with the order and never shrunk. */
typedef struct cseries {
  int built, nc, cap;          /* built: 1, or -1 when it cannot be      */
  int *m;                      /* the orders it was built for (nc)        */
  dplan **plan;                /* nc                                      */
  double ***inp;               /* nc x ninputs: input series in place     */
  double **mb_inp;             /* the mass-bias plan's (ninputs)          */
  const double **Aser;         /* nc x k: the series of A's entries       */
  const double **Mser;         /* k x k: of M's                           */
  const double **phi;          /* nc: of Phi                              */
  double *S, *rhs, *qdd, *lam, *H, *in0;
  nz_lu *lu;
} cseries;

static void cseries_free(cseries *w)
{
  if (!w) return;
  for (int r = 0; r < w->nc; r++) {
    if (w->plan) nz_dplan_free(w->plan[r]);
    if (w->inp) free(w->inp[r]);
  }
  free(w->m);
  free(w->plan);
  free(w->inp);
  free(w->mb_inp);
  free(w->Aser);
  free(w->Mser);
  free(w->phi);
  free(w->S);
  nz_lu_free(w->lu);
  free(w);
}

void nz_recording_constrained_series_free(nz_recording *c)
{
  cseries_free(c->cs);
  c->cs = NULL;
}

/* The plans of Phi_r and A_r for the orders m[r]: NZ_OK, or NZ_EARG with
 * the reason in c->failure (a constraint not recorded, of order > 2, or
 * reading a derivative above its order: its series would need coefficients
 * of q not known yet). */
static int cseries_plans(nz_recording *c, const int *m)
{
  cseries *w = c->cs;
  int k = c->k, nc = c->nc;
  if (w && w->built > 0) {
    int same = 1;
    for (int r = 0; r < nc; r++) same &= w->m[r] == m[r];
    if (same) return NZ_OK;
  }
  cseries_free(w);
  c->cs = w = calloc(1, sizeof *w);
  if (!w) return NZ_ENOMEM;
  w->nc = nc;
  w->m = malloc((size_t)nc * sizeof *w->m);
  w->plan = calloc((size_t)nc, sizeof *w->plan);
  w->inp = calloc((size_t)nc, sizeof *w->inp);
  w->mb_inp = malloc((size_t)c->ninputs * sizeof *w->mb_inp);
  w->Aser = malloc((size_t)nc * (size_t)k * sizeof *w->Aser);
  w->Mser = malloc((size_t)k * (size_t)k * sizeof *w->Mser);
  w->phi = malloc((size_t)nc * sizeof *w->phi);
  w->lu = nz_lu_new(k + nc);
  int *out = malloc((size_t)(3 + k + NZ_CONSTRAINT_SLOTS) * sizeof(int)), *po = malloc((size_t)(k + 1) * sizeof(int));
  if (!w->m || !w->plan || !w->inp || !w->mb_inp || !w->Aser || !w->Mser || !w->phi || !w->lu || !out || !po) {
    free(out);
    free(po);
    return NZ_ENOMEM;
  }
  memcpy(w->m, m, (size_t)nc * sizeof *m);
  w->built = -1;
  int st = NZ_OK;
  for (int r = 0; r < nc && !st; r++) {
    if (m[r] < 0 || m[r] > 2) {
      snprintf(c->failure, sizeof c->failure, "constraint %d is of order %d: taylor takes orders 0, 1, 2", r + 1, m[r]);
      st = NZ_EARG;
    } else if (!c->phi[r].n || c->nslots < NZ_CONSTRAINT_SLOTS + 2) {
      snprintf(c->failure, sizeof c->failure, "constraint %d is not recorded", r + 1);
      st = NZ_EARG;
    } else if (m[r] < 2 && nz_graph_reads_inputs(c->g, c->phi[r].nodes[0], nz_recording_input_slot(c, m[r] + 1, 0),
                                        nz_recording_input_slot(c, c->nslots - 1, k - 1))) {
      snprintf(c->failure, sizeof c->failure,
               "constraint %d is of order %d but its function reads higher derivatives of q", r + 1, m[r]);
      st = NZ_EARG;
    } else if (nz_recording_build_row(c, r, m[r], out)) {
      snprintf(c->failure, sizeof c->failure, "constraint %d: its gradient could not be built on the graph", r + 1);
      st = NZ_EARG;
    } else {
      po[0] = out[0];
      memcpy(po + 1, out + (2 - m[r]) + 1, (size_t)k * sizeof(int));
      if (!(w->plan[r] = nz_dplan_new(c->g, po, k + 1)) ||
          !(w->inp[r] = malloc((size_t)c->ninputs * sizeof *w->inp[r])))
        st = NZ_ENOMEM;
    }
  }
  free(out);
  free(po);
  if (!st) w->built = 1;
  return st;
}

/* The workspace for series of N + 1 coefficients of q''. */
static int cseries_workspace(nz_recording *c, int N)
{
  cseries *w = c->cs;
  if (N <= w->cap && w->S) return NZ_OK;
  int k = c->k, nc = c->nc, n = k + nc;
  size_t len = (size_t)n * (size_t)n + (size_t)n + (size_t)(N + 1) * (size_t)(k + nc) + (size_t)k * (size_t)k * (size_t)nc +
               (size_t)c->ninputs;
  double *S = malloc(len * sizeof *S);
  if (!S) return NZ_ENOMEM;
  free(w->S);
  w->S = S;
  w->rhs = S + (size_t)n * (size_t)n;
  w->qdd = w->rhs + n;
  w->lam = w->qdd + (size_t)(N + 1) * (size_t)k;
  w->H = w->lam + (size_t)(N + 1) * (size_t)nc;
  w->in0 = w->H + (size_t)k * (size_t)k * (size_t)nc;
  w->cap = N;
  return NZ_OK;
}

/* Coefficient j of slot s of q along the series: a_{j+s} (j+s)! / j!
 * (j + s <= top: a known coefficient; the unknown one is 0 here). */
static double slot_coef(const double *a, int k, int i, int s, int j, int top)
{
  if (j + s > top) return 0.0;
  double f = 1.0;
  for (int x = j + 1; x <= j + s; x++) f *= x;
  return f * a[(size_t)(j + s) * (size_t)k + (size_t)i];
}

/* Write coefficient j of every input of a plan (q's slots from a[0..top],
 * t = t0 + tau, parameters constant) in place. */
static void cseries_put(const nz_recording *c, double *const *ip, int j, double t0, const double *a, int top)
{
  int k = c->k;
  if (ip[0]) ip[0][j] = j == 0 ? t0 : j == 1 ? 1.0 : 0.0;
  for (int p = 0; p < c->np; p++)
    if (ip[1 + p]) ip[1 + p][j] = j == 0 ? c->params[p] : 0.0;
  for (int s = 0; s < c->nslots; s++)
    for (int i = 0; i < k; i++) {
      double *x = ip[nz_recording_input_slot(c, s, i)];
      if (x) x[j] = s <= 2 ? slot_coef(a, k, i, s, j, top) : 0.0;
    }
}

int nz_recording_constrained_series(nz_recording *c, const int *orders, double t0, const double *q0,
                                   const double *qd0, const double *qdd0, const double *lam0, int p, double *a,
                                   double *lambda)
{
  return nz_recording_constrained_series_sel(c, orders, NULL, t0, q0, qd0, qdd0, lam0, p, a, lambda);
}

int nz_recording_series(void *ctx, const int *orders, const nz_series_selection *sel, double t0, const double *q0,
                       const double *qd0, const double *qdd0, const double *lam0, int p, double *a)
{
  if (!orders) return nz_recording_motion_series(ctx, t0, q0, qd0, p, a);
  return nz_recording_constrained_series_sel(ctx, orders, sel, t0, q0, qd0, qdd0, lam0, p, a, NULL);
}

/* The rows held: every constraint, or the selection's (a contact mode);
 * row x is constraint row_of(x), and its force rides on a second row
 * couple_of(x) with the coefficient coef_of(x) (a sliding contact's
 * friction). */
static inline int row_of(const nz_series_selection *sel, int x) { return sel ? sel->rows[x] : x; }
static inline int couple_of(const nz_series_selection *sel, int x) { return sel && sel->couple ? sel->couple[x] : -1; }
static inline double coef_of(const nz_series_selection *sel, int x) { return sel && sel->coef ? sel->coef[x] : 0.0; }

/* Coefficient 0 of every plan (M and h to order N, the rows held to
 * N + 2); the constraint plans then up to their coefficient 2 - m, the one
 * order 0 settled.  On a plan's failure *fail is that plan. */
static int cseries_begin(nz_recording *c, const int *orders, const nz_series_selection *sel, int na, double t0,
                         const double *q0, const double *qd0, const double *qdd0, int N, double *a,
                         nz_graph_plan **fail)
{
  int k = c->k, st;
  cseries *w = c->cs;
  nz_graph_plan *mb = c->mb_plan->plan;
  double *in = w->in0;
  memset(in, 0, (size_t)c->ninputs * sizeof(double));
  in[0] = t0;
  for (int q = 0; q < c->np; q++) in[1 + q] = c->params[q];
  for (int i = 0; i < k; i++) {
    in[nz_recording_input_slot(c, 0, i)] = q0[i];
    in[nz_recording_input_slot(c, 1, i)] = qd0[i];
    in[nz_recording_input_slot(c, 2, i)] = qdd0[i];
  }
  *fail = mb;
  if ((st = nz_graph_series_begin(mb, N, in))) return st;
  nz_graph_series_inputs(mb, w->mb_inp, c->ninputs);
  *fail = NULL;
  for (int e = 0; e < k * k; e++)
    if (!(w->Mser[e] = nz_graph_series_node(mb, c->mb_plan->outs[e]))) return NZ_EARG;
  for (int x = 0; x < na; x++)
    for (int pass = 0; pass < 2; pass++) {   /* the row, then the row its force rides on */
      int r = pass ? couple_of(sel, x) : row_of(sel, x);
      if (r < 0) continue;
      nz_graph_plan *pr = w->plan[r]->plan;
      *fail = pr;
      if ((st = nz_graph_series_begin(pr, N + 2, in))) return st;
      nz_graph_series_inputs(pr, w->inp[r], c->ninputs);
      w->phi[r] = nz_graph_series_node(pr, w->plan[r]->outs[0]);
      for (int i = 0; i < k; i++) w->Aser[r * k + i] = nz_graph_series_node(pr, w->plan[r]->outs[1 + i]);
      for (int j = 1; !pass && j <= 2 - orders[r]; j++) {
        cseries_put(c, w->inp[r], j, t0, a, 2);
        if ((st = nz_graph_series_next(pr, j, NULL, NULL))) return st;
      }
    }
  return NZ_OK;
}

/* The saddle-point matrix of every order n >= 1, [M_0 - sum lambda0_r
 * H_r, -W_0^T; A_0, 0], H_r = dA_r/dq'' (zero unless constraint r is of
 * order 2 and not linear in q''), W the forces' rows (A, or A + CF D),
 * factored once (into w->lu) when N >= 1. */
static int cseries_saddle(nz_recording *c, const int *orders, const nz_series_selection *sel, int na, double t0,
                          const double *lam0, int N, const double *a, nz_graph_plan **fail)
{
  int k = c->k, n2 = k + na, st;
  cseries *w = c->cs;
  double *S = w->S, *H = w->H;
  memset(H, 0, (size_t)k * (size_t)k * (size_t)c->nc * sizeof(double));
  if (N >= 1)
    for (int x = 0; x < na; x++) {
      int r = row_of(sel, x);
      if (orders[r] != 2) continue;
      /* dA_r/dq'' by probing coefficient 1: it is affine in q''_1 with that
       * slope (the chain rule of the top coefficient), exactly */
      nz_graph_plan *pr = w->plan[r]->plan;
      *fail = pr;
      double *base = w->rhs;   /* free until the orders' loop */
      cseries_put(c, w->inp[r], 1, t0, a, 2);
      if ((st = nz_graph_series_next(pr, 1, NULL, NULL))) return st;
      for (int i = 0; i < k; i++) base[i] = w->Aser[r * k + i][1];
      for (int j = 0; j < k; j++) {
        double *xin = w->inp[r][nz_recording_input_slot(c, 2, j)];
        if (!xin) continue;   /* A_r does not read q''_j */
        xin[1] = 1.0;
        if ((st = nz_graph_series_next(pr, 1, NULL, NULL))) return st;
        for (int i = 0; i < k; i++)
          H[((size_t)x * (size_t)k + (size_t)i) * (size_t)k + (size_t)j] = w->Aser[r * k + i][1] - base[i];
        xin[1] = 0.0;
      }
    }
  *fail = NULL;
  for (int i = 0; i < k; i++) {
    for (int j = 0; j < k; j++) {
      double v = w->Mser[i * k + j][0];
      for (int x = 0; x < na; x++) v -= lam0[x] * H[((size_t)x * (size_t)k + (size_t)i) * (size_t)k + (size_t)j];
      S[(size_t)i * (size_t)n2 + (size_t)j] = v;
    }
    for (int x = 0; x < na; x++) {
      double f = w->Aser[row_of(sel, x) * k + i][0];
      if (couple_of(sel, x) >= 0) f += coef_of(sel, x) * w->Aser[couple_of(sel, x) * k + i][0];
      S[(size_t)i * (size_t)n2 + (size_t)(k + x)] = -f;
    }
  }
  for (int x = 0; x < na; x++) {
    for (int j = 0; j < k; j++) S[(size_t)(k + x) * (size_t)n2 + (size_t)j] = w->Aser[row_of(sel, x) * k + j][0];
    for (int j = 0; j < na; j++) S[(size_t)(k + x) * (size_t)n2 + (size_t)(k + j)] = 0.0;
  }
  if (N >= 1 && (st = nz_lu_factor(w->lu, n2, S))) {
    snprintf(c->failure, sizeof c->failure, "the saddle-point matrix [M A^T; A 0] is singular");
    return st;
  }
  return NZ_OK;
}

/* The right-hand side of order n >= 1 into w->rhs: -(h_n + sum M_j
 * q''_{n-j}) for the coordinates, then each row's coefficient n + 2 - m at
 * q''_n = 0 in q''_n's units, with the forces' known part added. */
static int cseries_rhs(nz_recording *c, const int *orders, const nz_series_selection *sel, int na, double t0,
                       int n, const double *a, nz_graph_plan **fail)
{
  int k = c->k, st;
  cseries *w = c->cs;
  nz_graph_plan *mb = c->mb_plan->plan;
  /* coefficient n of M and h: q to a_{n+1}, known */
  *fail = mb;
  cseries_put(c, w->mb_inp, n, t0, a, n + 1);
  if ((st = nz_graph_series_next(mb, n, NULL, NULL))) return st;
  double *u = w->rhs;
  for (int i = 0; i < k; i++) {
    double s = nz_graph_series_coef(mb, k * k + i, n);   /* h_i */
    for (int j = 1; j <= n; j++)
      for (int x = 0; x < k; x++) s += w->Mser[i * k + x][j] * w->qdd[(size_t)(n - j) * (size_t)k + (size_t)x];
    u[i] = -s;
  }
  /* the constraints: coefficient n + 2 - m of Phi_r with q''_n = 0 ... */
  for (int x = 0; x < na; x++) {
    int r = row_of(sel, x), m = orders[r], j = n + 2 - m, d = couple_of(sel, x);
    nz_graph_plan *pr = w->plan[r]->plan;
    *fail = pr;
    cseries_put(c, w->inp[r], j, t0, a, n + 1);
    if ((st = nz_graph_series_next(pr, j, NULL, NULL))) return st;
    /* ... is affine in q''_n with slope A_r0 times (slot m's coefficient
     * j per unit of q''_n): 1 / ((n+1)(n+2)), 1 / (n+1), 1, so that
     * dividing by it is multiplying by an integer (one rounding, no bias) */
    double per = m == 0 ? (double)(n + 1) * (double)(n + 2) : m == 1 ? (double)(n + 1) : 1.0;
    u[k + x] = -w->phi[r][j] * per;
    if (d >= 0) {
      /* the row the force rides on, to its coefficient n: it reads q and
       * q' at most (order <= 1), known to a_{n+1} */
      nz_graph_plan *pd = w->plan[d]->plan;
      *fail = pd;
      cseries_put(c, w->inp[d], n, t0, a, n + 1);
      if ((st = nz_graph_series_next(pd, n, NULL, NULL))) return st;
    }
    /* W^T lambda's coefficient n without W_0^T lambda_n (in the matrix):
     * sum_{i=1..n} W_i^T lambda_{n-i}, A_n at q''_n = 0 (its part in
     * q''_n is the matrix's H) */
    for (int y = 0; y < k; y++) {
      double s = 0.0;
      for (int i = 1; i <= n; i++) {
        double f = w->Aser[r * k + y][i];
        if (d >= 0) f += coef_of(sel, x) * w->Aser[d * k + y][i];
        s += f * w->lam[(size_t)(n - i) * (size_t)na + (size_t)x];
      }
      u[y] += s;
    }
  }
  return NZ_OK;
}

/* Order n >= 1: solve for q''_n and lambda_n, store a_{n+2}, and run the
 * constraint plans' coefficient n + 2 - m again with q''_n. */
static int cseries_order(nz_recording *c, const int *orders, const nz_series_selection *sel, int na, double t0,
                         int n, double *a, nz_graph_plan **fail)
{
  int k = c->k, st;
  cseries *w = c->cs;
  if ((st = cseries_rhs(c, orders, sel, na, t0, n, a, fail))) return st;
  *fail = NULL;
  double *u = w->rhs;
  if ((st = nz_lu_solve(w->lu, u))) {
    snprintf(c->failure, sizeof c->failure, "the saddle-point matrix could not be solved at order %d", n);
    return st;
  }
  double *qn = w->qdd + (size_t)n * (size_t)k, *ln = w->lam + (size_t)n * (size_t)na;
  for (int i = 0; i < k; i++) {
    if (!isfinite(u[i])) {
      snprintf(c->failure, sizeof c->failure, "coefficient %d of q''_%d is not finite", n, i + 1);
      return isnan(u[i]) ? NZ_ENAN : NZ_ERANGE;
    }
    qn[i] = u[i];
    a[(size_t)(n + 2) * (size_t)k + (size_t)i] = nz_series_ode2_coef(u[i], n);
  }
  for (int x = 0; x < na; x++) ln[x] = u[k + x];
  for (int x = 0; x < na; x++) {
    int r = row_of(sel, x), j = n + 2 - orders[r];
    nz_graph_plan *pr = w->plan[r]->plan;
    *fail = pr;
    cseries_put(c, w->inp[r], j, t0, a, n + 2);
    if ((st = nz_graph_series_next(pr, j, NULL, NULL))) return st;
  }
  return NZ_OK;
}

int nz_recording_constrained_series_sel(nz_recording *c, const int *orders, const nz_series_selection *sel, double t0,
                                       const double *q0, const double *qd0, const double *qdd0, const double *lam0,
                                       int p, double *a, double *lambda)
{
  int k = c->k, st;
  int na = sel ? sel->n : c->nc;
  if (p < 2 || p > NZ_JET_MAX_ORDER) return NZ_EDOM;
  if (na < 0 || na > c->nc) return NZ_EARG;
  if (!nz_recording_mass_bias_ready(c)) return NZ_EARG;
  if ((st = cseries_plans(c, orders))) return st;
  int N = p - 2;   /* the coefficients 0 .. N of q'' give a_2 .. a_p */
  if ((st = cseries_workspace(c, N))) return st;
  cseries *w = c->cs;
  memcpy(a, q0, (size_t)k * sizeof(double));
  memcpy(a + k, qd0, (size_t)k * sizeof(double));
  for (int i = 0; i < k; i++) a[2 * k + i] = qdd0[i] * 0.5;
  memcpy(w->qdd, qdd0, (size_t)k * sizeof(double));
  memcpy(w->lam, lam0, (size_t)na * sizeof(double));
  /* a plan that fails (fail set) is named in c->failure here; the other
   * failures name themselves */
  nz_graph_plan *fail = NULL;
  if (!(st = cseries_begin(c, orders, sel, na, t0, q0, qd0, qdd0, N, a, &fail)) &&
      !(st = cseries_saddle(c, orders, sel, na, t0, lam0, N, a, &fail)))
    for (int n = 1; n <= N && !st; n++) st = cseries_order(c, orders, sel, na, t0, n, a, &fail);
  if (st) {
    if (fail) nz_recording_describe_failure(c, fail, st);
    return st;
  }
  if (lambda) memcpy(lambda, w->lam, (size_t)(N + 1) * (size_t)na * sizeof(double));
  return NZ_OK;
}
