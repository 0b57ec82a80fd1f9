/* mech_graph.c - a system's recorded pieces behind nz_evaluator, and the
 * mass matrix and bias derived from them (mech_graph.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mech/mech_graph_impl.h"
#include "graph/graph_rounding.h"

void nz_dplan_free(dplan *d)
{
  if (!d) return;
  if (d->ser) nz_series_native_detach(d->plan);
  nz_series_native_free(d->ser);
  nz_series_native_free(d->ser_compiling);
  nz_graph_plan_free(d->plan);
  nz_native_free(d->native);
  nz_native_free(d->compiling);
  free(d->outs);
  free(d);
}

dplan *nz_dplan_new(const nz_graph *g, const int *outs, int n)
{
  dplan *d = calloc(1, sizeof *d);
  if (!d) return NULL;
  d->outs = malloc((size_t)n * sizeof(int));
  d->plan = nz_graph_plan_new(g, outs, n);
  if (!d->outs || !d->plan) { nz_dplan_free(d); return NULL; }
  memcpy(d->outs, outs, (size_t)n * sizeof(int));
  d->nout = n;
  /* Compiling costs about NZ_NATIVE_BASE node evaluations plus
   * NZ_NATIVE_PER_NODE per node of the plan; in the background it costs
   * the run nothing but a core for a while, so it starts once the plan has
   * shown it is used (a sixteenth of that): a one-off sys:accel does not
   * compile, a run of a few milliseconds leaves the object in the cache. */
  d->start = (NZ_NATIVE_BASE + NZ_NATIVE_PER_NODE * nz_graph_plan_nodes(d->plan)) / NZ_NATIVE_START_FRACTION;
  return d;
}

/* The cache directory, or 0 with the reason kept for graph_info. */
static int cache_dir(nz_recording *c, char *dir, size_t n)
{
  char why[300];
  if (nz_native_cache_dir(dir, n, why, sizeof why)) return 1;
  snprintf(c->native_why, sizeof c->native_why, "%s", why);
  return 0;
}

/* A plan whose object is already in the cache runs natively at once
 * (auto and on; loading costs microseconds per node).  An untrusted cache
 * says why. */
static void dplan_load_cached(nz_recording *c, dplan *d)
{
  char dir[1024], why[300];
  if (c->native_mode == 0 || !cache_dir(c, dir, sizeof dir)) return;
  if ((d->native = nz_native_load(c->g, d->outs, d->nout, dir, why, sizeof why))) {
    d->tried = 1;
    c->native_count++;
  } else if (strcmp(why, "not in the cache"))
    snprintf(c->native_why, sizeof c->native_why, "%s", why);
}

/* The object is loaded: count it, and its compile's time. */
static void dplan_switch(nz_recording *c, dplan *d, nz_native *f)
{
  d->native = f;
  c->native_count++;
  c->native_seconds += nz_native_compile_seconds(f);
  c->native_waited += nz_native_waited(f);
  if (d->used) c->plans_native++;
}

/* Compile d: in the background (auto mode), or now, waiting (native on). */
static void dplan_compile(nz_recording *c, dplan *d, int wait)
{
  char dir[1024];
  d->tried = 1;
  if (!cache_dir(c, dir, sizeof dir)) return;
  nz_native *f = wait ? nz_native_compile(c->g, d->outs, d->nout, dir, c->native_why, sizeof c->native_why)
                      : nz_native_start(c->g, d->outs, d->nout, dir, c->native_why, sizeof c->native_why);
  if (!f) return;
  if (nz_native_ready(f, 0, NULL, 0) == 0) dplan_switch(c, d, f);
  else {
    d->compiling = f;
    c->compiling++;
  }
}

/* A compile under way: loaded now (wait = 1: once it is done)? */
static void dplan_poll(nz_recording *c, dplan *d, int wait)
{
  int r = nz_native_ready(d->compiling, wait, c->native_why, sizeof c->native_why);
  if (r == 1) return;
  nz_native *f = d->compiling;
  d->compiling = NULL;
  c->compiling--;
  if (r == 0) dplan_switch(c, d, f);
  else nz_native_free(f);
}

/* A series compile under way: attached now (wait = 1: once it is done)? */
static void dplan_series_poll(nz_recording *c, dplan *d, int wait)
{
  int r = nz_series_native_ready(d->ser_compiling, wait, c->native_why, sizeof c->native_why);
  if (r == 1) return;
  nz_series_native *s = d->ser_compiling;
  d->ser_compiling = NULL;
  c->compiling--;
  if (r < 0) {
    nz_series_native_free(s);
    return;
  }
  d->ser = s;
  nz_series_native_attach(s, d->plan);
  c->native_count++;
  c->native_series++;
  if (d->ser_used) c->series_native++;
  c->native_seconds += nz_series_native_seconds(s);
  c->native_waited += nz_series_native_waited(s);
}

/* After a begin of d's series to order N: its machine code, on the policy
 * of the plans on doubles (in node coefficients, about 4 ns each
 * interpreted: NZ_SERIES_NATIVE_PER_NODE), or at once when cached.  A
 * compile in the background is attached at a later begin, once ready. */
void nz_dplan_series_native(nz_recording *c, dplan *d, int N, const nz_series_ode2 *ode2)
{
  if (!d->ser_used) {
    d->ser_used = 1;
    c->series_used++;
    if (d->ser) c->series_native++;
  }
  if (d->ser_compiling) {
    /* a system call: not at every step */
    if (c->native_mode == 1 || ++d->polls % 16 == 0) dplan_series_poll(c, d, c->native_mode == 1);
    return;
  }
  if (d->ser_tried || c->native_mode == 0) return;
  int nodes = nz_graph_plan_nodes(d->plan);
  d->ser_work += (double)nodes * N;
  int compile = c->native_mode == 1 ||
                d->ser_work >= (NZ_SERIES_NATIVE_BASE + NZ_SERIES_NATIVE_PER_NODE * nodes) / NZ_NATIVE_START_FRACTION;
  /* the first call looks in the cache (generating and hashing the source
   * costs microseconds per node, once); later ones only count, until
   * compiling is worth starting */
  if (!compile && d->ser_looked) return;
  d->ser_looked = 1;
  char dir[1024], why[300];
  if (!cache_dir(c, dir, sizeof dir)) {
    d->ser_tried = 1;
    return;
  }
  nz_series_native *s = nz_series_native_get(d->plan, ode2, dir, compile ? (c->native_mode == 1 ? 1 : 2) : 0, why,
                                             sizeof why);
  d->ser_tried = s || compile;
  if (!s) {
    if (compile || strcmp(why, "not in the cache")) snprintf(c->native_why, sizeof c->native_why, "%s", why);
    return;
  }
  d->ser_compiling = s;
  c->compiling++;
  dplan_series_poll(c, d, c->native_mode == 1);   /* it may be loaded already */
}

/* Evaluate on doubles: natively when compiled (its refusal is confirmed by
 * the interpreter, which names the node), else interpreted. */
static inline nz_status dplan_eval(nz_recording *c, dplan *d, const double *in, double *out)
{
  if (!d->used) {                      /* a compile that loads later counts it native then (dplan_switch) */
    d->used = 1;
    c->plans_used++;
    c->plans_native += d->native != NULL;
  }
  if (!d->native) {
    if (d->compiling) {
      if (++d->polls % 64 == 0) dplan_poll(c, d, 0);   /* a system call: not at every evaluation */
    } else if (!d->tried && (c->native_mode == 1 || (c->native_mode < 0 && d->work >= d->start)))
      dplan_compile(c, d, c->native_mode == 1);
  }
  if (d->native) {
    if (nz_native_eval(d->native, in, out) == NZ_OK) return NZ_OK;
  }
  d->work += nz_graph_plan_nodes(d->plan);
  return nz_graph_eval(d->plan, in, out);
}

/* Every plan on doubles and every series evaluated so far runs as machine
 * code (the evaluator of the steps from now on). */
int nz_recording_all_native(void *ctx)
{
  const nz_recording *c = ctx;
  if (c->native_mode == 0) return -1;
  return c->plans_used == c->plans_native && c->series_used == c->series_native;
}

/* Wait for every compile under way. */
void nz_recording_native_wait(nz_recording *c)
{
  dplan *all[2] = { c->mb_plan, c->acc_plan };
  for (int i = 0; i < 2; i++)
    if (all[i] && all[i]->compiling) dplan_poll(c, all[i], 1);
  for (int r = 0; c->rows && r < 3 * c->nc; r++)
    if (c->rows[r] && c->rows[r]->compiling) dplan_poll(c, c->rows[r], 1);
  for (int i = 0; i < 2; i++)
    if (all[i] && all[i]->ser_compiling) dplan_series_poll(c, all[i], 1);
}

int nz_recording_native_compiling(const nz_recording *c) { return c->compiling; }
int nz_recording_native_mode(const nz_recording *c) { return c->native_mode; }
double nz_recording_native_waited(const nz_recording *c) { return c->native_waited; }

int nz_recording_native_series(const nz_recording *c) { return c->native_series; }

void nz_recording_set_native(nz_recording *c, int mode) { c->native_mode = mode < 0 ? -1 : mode > 0; }

int nz_recording_native(const nz_recording *c, double *seconds, const char **why)
{
  if (seconds) *seconds = c->native_seconds;
  if (why) *why = c->native_why[0] ? c->native_why : NULL;
  return c->native_count;
}

nz_recording *nz_recording_new(int k, int np, int nc, int nslots)
{
  if (k < 1 || np < 0 || nc < 0) return NULL;
  if (nslots < 2) nslots = 2;
  nz_recording *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  c->k = k; c->np = np; c->nc = nc; c->nslots = nslots;
  c->ninputs = 1 + np + nslots * k + k;   /* the frozen velocities last (mech_graph.h) */
  c->g = nz_graph_new();
  c->params = calloc((size_t)np + 1, sizeof(double));
  c->phi = calloc((size_t)nc + 1, sizeof(compiled_piece));
  c->in = calloc((size_t)c->ninputs, sizeof(nz_jet *));
  c->din = calloc((size_t)c->ninputs, sizeof(nz_jet *));
  c->pjet = calloc((size_t)np + 1, sizeof(nz_jet *));
  c->pcap = -1;
  c->native_mode = -1;
  const char *env = getenv("NZLUA_NATIVE");
  if (env && (env[0] == '0' || env[0] == '1') && env[1] == '\0') c->native_mode = env[0] - '0';
  c->rows = calloc(3 * (size_t)nc + 1, sizeof(dplan *));
  c->rows_built = calloc(3 * (size_t)nc + 1, 1);
  c->row_in = calloc((size_t)c->ninputs, sizeof(double));
  c->row_guards = calloc(3 * (size_t)nc + 1, sizeof(nz_graph_guards *));
  c->row_outs = calloc(3 * (size_t)nc + 1, sizeof(double *));
  if (!c->g || !c->params || !c->phi || !c->in || !c->din || !c->pjet || !c->rows || !c->rows_built ||
      !c->row_in || !c->row_guards || !c->row_outs) {
    nz_recording_free(c);
    return NULL;
  }
  return c;
}

static void piece_clear(compiled_piece *p)
{
  free(p->nodes);
  nz_graph_plan_free(p->plan);
  memset(p, 0, sizeof *p);
}

void nz_recording_free(nz_recording *c)
{
  if (!c) return;
  for (int p = 0; p < NZ_PIECE_COUNT; p++) piece_clear(&c->piece[p]);
  for (int r = 0; c->phi && r < c->nc; r++) piece_clear(&c->phi[r]);
  for (int p = 0; c->pjet && p < c->np; p++) nz_jet_free(c->pjet[p]);
  nz_dplan_free(c->mb_plan);
  nz_dplan_free(c->acc_plan);
  nz_graph_guards_free(c->mb_guards);
  nz_graph_guards_free(c->acc_guards);
  free(c->acc_out);
  for (int r = 0; c->rows && r < 3 * c->nc; r++) nz_dplan_free(c->rows[r]);
  for (int r = 0; c->row_guards && r < 3 * c->nc; r++) nz_graph_guards_free(c->row_guards[r]);
  for (int r = 0; c->row_outs && r < 3 * c->nc; r++) free(c->row_outs[r]);
  free(c->row_guards);
  free(c->row_outs);
  free(c->rows);
  free(c->rows_built);
  free(c->row_in);
  free(c->ts_in);
  free(c->ts_M);
  free(c->ts_inp);
  nz_recording_constrained_series_free(c);
  free(c->ts_pos);
  free(c->mb_in);
  free(c->acc_A);
  free(c->phi);
  free(c->pjet);
  free(c->in);
  free(c->din);
  free(c->params);
  nz_graph_free(c->g);
  free(c);
}

nz_graph *nz_recording_graph(nz_recording *c) { return c->g; }
double *nz_recording_params(nz_recording *c) { return c->params; }
int nz_recording_nparams(const nz_recording *c) { return c->np; }
const char *nz_recording_failure(const nz_recording *c) { return c->failure; }

int nz_recording_input_slot(const nz_recording *c, int j, int i)
{
  return 1 + c->np + j * c->k + i;
}

int nz_recording_input_frozen(const nz_recording *c, int i) { return 1 + c->np + c->nslots * c->k + i; }
int nz_recording_nslots(const nz_recording *c) { return c->nslots; }
int nz_recording_ncoords(const nz_recording *c) { return c->k; }

static compiled_piece *piece_of(const nz_recording *c, nz_piece piece, int index)
{
  if (piece == NZ_PIECE_PHI) return index >= 0 && index < c->nc ? &c->phi[index] : NULL;
  return piece >= 0 && piece < NZ_PIECE_COUNT ? (compiled_piece *)&c->piece[piece] : NULL;
}

int nz_recording_set_piece(nz_recording *c, nz_piece piece, int index, const int *nodes, int n)
{
  compiled_piece *p = piece_of(c, piece, index);
  if (!p || n != (piece == NZ_PIECE_Q ? c->k : 1)) return NZ_EARG;
  for (int o = 0; o < n; o++)
    if (nodes[o] < 0 || nodes[o] >= nz_graph_size(c->g)) return NZ_EARG;
  if (nz_graph_ninputs(c->g) > c->ninputs) return NZ_EARG;
  piece_clear(p);
  p->nodes = malloc((size_t)n * sizeof(int));
  if (!p->nodes) return NZ_ENOMEM;
  memcpy(p->nodes, nodes, (size_t)n * sizeof(int));
  p->plan = nz_graph_plan_new(c->g, nodes, n);
  if (!p->plan) { piece_clear(p); return NZ_ENOMEM; }
  p->n = n;
  return NZ_OK;
}

int nz_recording_has(const nz_recording *c, nz_piece piece, int index)
{
  const compiled_piece *p = piece_of(c, piece, index);
  return p && p->n > 0;
}

int nz_recording_piece_nodes(const nz_recording *c, nz_piece piece, int index)
{
  const compiled_piece *p = piece_of(c, piece, index);
  return p && p->n > 0 ? nz_graph_plan_nodes(p->plan) : 0;
}

/* The parameters as constant jets of (at least) this order. */
static int param_jets(nz_recording *c, int order)
{
  if (order > c->pcap) {
    for (int p = 0; p < c->np; p++) {
      nz_jet_free(c->pjet[p]);
      if (!(c->pjet[p] = nz_jet_alloc(order, 0))) return NZ_ENOMEM;
    }
    c->pcap = order;
  }
  for (int p = 0; p < c->np; p++) {
    nz_jet_init(c->pjet[p], order, 0);
    nz_jet_set_constant(c->pjet[p], c->params[p]);
  }
  return NZ_OK;
}

void nz_recording_describe_failure(nz_recording *c, const nz_graph_plan *plan, int st)
{
  int node;
  nz_gop op;
  nz_jet_fn fn;
  double x;
  nz_graph_plan_failure(plan, &node, &op, &fn, &x);
  const char *name = op == NZ_GOP_FN && fn < NZ_FN_COUNT ? nz_jet_fn_names[fn]
                   : op < NZ_GOP_COUNT ? nz_gop_names[op] : "?";
  snprintf(c->failure, sizeof c->failure, "%s of %.17g failed (status %d, node %d)", name, x, st,
           node);
}

int nz_recording_eval(void *ctx, nz_piece piece, int index, const nz_jet *t,
                     nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
                     const nz_direction *dir)
{
  nz_recording *c = ctx;
  compiled_piece *p = piece_of(c, piece, index);
  if (!p || p->n == 0) return NZ_EARG;
  int st = param_jets(c, t->order);
  if (st) return st;
  c->in[0] = t;
  c->din[0] = dir ? dir->dt : NULL;
  for (int q = 0; q < c->np; q++) {
    c->in[1 + q] = c->pjet[q];
    c->din[1 + q] = NULL;
  }
  for (int j = 0; j < c->nslots; j++)
    for (int i = 0; i < c->k; i++) {
      int at = nz_recording_input_slot(c, j, i);
      c->in[at] = j < nlevels ? levels[j][i] : NULL;
      c->din[at] = dir && j < nlevels ? dir->dlevels[j][i] : NULL;
    }
  st = nz_graph_eval_jets(p->plan, c->in, out, dir ? c->din : NULL, dir ? dir->dout : NULL);
  if (st) nz_recording_describe_failure(c, p->plan, st);
  return st;
}

/* ------------------------------------------------------------------ */
/* Mass matrix and bias, differentiated once                           */

/* A direction in which no input moves (dinput of nz_graph_derivative). */
static void no_motion(int *dir, int n)
{
  for (int a = 0; a < n; a++) dir[a] = -1;
}

/* Graph nodes of M (k x k), h (k), then F and V (checked, not used), into
 * out[k k + k + 2]; -1 on failure. */
static int build_mass_bias(nz_recording *c, int *out)
{
  nz_graph *g = c->g;
  int k = c->k, n = c->ninputs;   /* nz_recording_set_piece keeps the graph's inputs within */
  int *dir = malloc((size_t)n * sizeof(int));
  int *grad = malloc((size_t)(3 * k) * sizeof(int));
  int ok = dir && grad;
  int one = nz_graph_const(g, 1.0), zero = nz_graph_const(g, 0.0);
  if (one < 0 || zero < 0) ok = 0;
  int F = c->piece[NZ_PIECE_F].n ? c->piece[NZ_PIECE_F].nodes[0] : zero;
  int *gq = grad, *gqd = grad + k, *tmp = grad + 2 * k;
  /* dF/dq_i and dF/dq'_i, one seed each */
  for (int i = 0; ok && i < k; i++)
    for (int s = 0; s < 2 && ok; s++) {
      no_motion(dir, n);
      dir[nz_recording_input_slot(c, s, i)] = one;
      int d = nz_graph_derivative(g, F, dir);
      if (d < 0) ok = 0;
      else (s ? gqd : gq)[i] = d;
    }
  /* M_ij = d(dF/dq'_i)/dq'_j */
  for (int j = 0; ok && j < k; j++) {
    no_motion(dir, n);
    dir[nz_recording_input_slot(c, 1, j)] = one;
    if (nz_graph_derivatives(g, gqd, k, dir, tmp)) ok = 0;
    for (int i = 0; ok && i < k; i++) out[i * k + j] = tmp[i];
  }
  /* d/dt (dF/dq'_i) with q'' = 0: along t -> 1, q -> q' */
  if (ok) {
    no_motion(dir, n);
    dir[0] = one;
    for (int j = 0; j < k; j++) dir[nz_recording_input_slot(c, 1, j)] = -1;
    for (int j = 0; j < k && ok; j++)
      if ((dir[nz_recording_input_slot(c, 0, j)] = nz_graph_input(g, nz_recording_input_slot(c, 1, j))) < 0)
        ok = 0;
    if (ok && nz_graph_derivatives(g, gqd, k, dir, tmp)) ok = 0;
  }
  /* h = d/dt dF/dq' - dF/dq + dV/dq - Q */
  int V = c->piece[NZ_PIECE_V].n ? c->piece[NZ_PIECE_V].nodes[0] : -1;
  for (int i = 0; ok && i < k; i++) {
    int h = nz_graph_op(g, NZ_GOP_SUB, tmp[i], gq[i]);
    if (V >= 0 && h >= 0) {
      no_motion(dir, n);
      dir[nz_recording_input_slot(c, 0, i)] = one;
      int dV = nz_graph_derivative(g, V, dir);
      h = dV < 0 ? -1 : nz_graph_op(g, NZ_GOP_ADD, h, dV);
    }
    if (c->piece[NZ_PIECE_Q].n && h >= 0) h = nz_graph_op(g, NZ_GOP_SUB, h, c->piece[NZ_PIECE_Q].nodes[i]);
    if (h < 0) ok = 0;
    out[k * k + i] = h;
  }
  /* F and V themselves, evaluated and dropped: the functions must be defined
   * where their derivatives are used (log x at x < 0 has the derivative 1/x,
   * but the user's V fails there, and so must we: the jet path then says
   * where). */
  out[k * k + k] = F;
  out[k * k + k + 1] = V >= 0 ? V : zero;
  free(dir);
  free(grad);
  return ok ? 0 : -1;
}

/* Is every node under root defined wherever its inputs are finite
 * (nz_graph_total)?  Then a finite output says the function was defined,
 * and F and V need not be evaluated beside the accelerations to be
 * checked: sums, products, whole non-negative powers, division by a
 * non-zero constant and sin, cos, tan, atan, tanh, sign qualify; log,
 * sqrt, abs (the jets refuse it at 0), a division by a node, exp (it
 * overflows at 710, while the accelerations may not see it: V = x^2/2 +
 * tanh(exp(t))) do not. */
static int defined_everywhere(const nz_graph *g, int root) { return root < 0 || nz_graph_total(g, root); }

/* The plan of outputs out[0..n-1] with its guards' nodes after them
 * (graph_guard.h; smooth: the functions the jets differentiate): the
 * plan, or NULL; *gd the guards (NULL when out of memory: no plan then). */
static dplan *guarded_plan(nz_recording *c, const int *out, int n, const int *smooth, int nsmooth,
                           nz_graph_guards **gd)
{
  /* the parameters (inputs 1..np) do not move along the motion */
  *gd = nz_graph_guards_new(c->g, out, n, smooth, nsmooth, 1, c->np);
  if (!*gd) return NULL;
  int ng = nz_graph_guards_count(*gd);
  int *all = malloc((size_t)(n + ng + 1) * sizeof(int));
  if (!all) return NULL;
  memcpy(all, out, (size_t)n * sizeof(int));
  memcpy(all + n, nz_graph_guards_nodes(*gd), (size_t)ng * sizeof(int));
  dplan *d = nz_dplan_new(c->g, all, n + ng);
  free(all);
  if (d) dplan_load_cached(c, d);
  return d;
}

/* After a plan's evaluation: does it meet a tie or a singular point that
 * the jets must decide (vals: its outputs, the guards' after its own n)? */
static int guards_fire(nz_recording *c, const nz_graph_guards *gd, const double *vals, int n)
{
  const char *what;
  if (!nz_graph_guards_fire(gd, vals + n, &what)) return 0;
  snprintf(c->failure, sizeof c->failure, "%s: the jets decide", what);
  return 1;
}

/* When every entry of M is a constant node, factor M once and build
 * q'' = -M^-1 h as a plan (M^-1 by k solves with unit right-hand sides), so
 * that an acceleration costs one pass.  No plan if M is not positive
 * definite: the general path reports that with the state. */
static void invert_constant_mass(nz_recording *c, const int *out)
{
  int k = c->k;
  double *M = c->acc_A, v;
  for (int e = 0; e < k * k; e++) {
    if (!nz_graph_is_const(c->g, out[e], &v)) return;
    M[e] = v;
  }
  double *minv = malloc((size_t)k * (size_t)k * sizeof(double));
  double *A = malloc((size_t)k * (size_t)k * sizeof(double));
  if (!minv || !A) { free(minv); free(A); return; }
  int ok = 1;
  for (int j = 0; j < k && ok; j++) {
    memcpy(A, M, (size_t)k * (size_t)k * sizeof(double));
    for (int i = 0; i < k; i++) c->acc_rhs[i] = i == j ? 1.0 : 0.0;
    /* column j of M^-1, into row j (M^-1 is symmetric) */
    ok = nz_solve_spd_in(k, A, c->acc_rhs, minv + (size_t)j * (size_t)k, 0.0, &c->m_info, c->acc_work) == NZ_OK;
  }
  free(A);
  /* q''_i = -sum_j (M^-1)_ij h_j, then F and V (checked) unless nothing in
   * them can be undefined (Cartesian coordinates and polynomial potentials:
   * a third of the plan of Henon-Heiles) */
  int checks = !(defined_everywhere(c->g, out[k * k + k]) && defined_everywhere(c->g, out[k * k + k + 1]));
  int *acc = ok ? malloc((size_t)(k + 2) * sizeof(int)) : NULL;
  for (int i = 0; acc && i < k; i++) {
    /* the terms with a zero entry of M^-1 add nothing (but a sign of 0) */
    int sum = -1;
    for (int j = 0; j < k; j++) {
      double mij = minv[(size_t)i * (size_t)k + (size_t)j];
      if (mij == 0.0) continue;
      int coef = nz_graph_const(c->g, -mij);
      int term = coef < 0 ? -1 : nz_graph_op(c->g, NZ_GOP_MUL, coef, out[k * k + j]);
      sum = term < 0 ? -1 : sum < 0 ? term : nz_graph_op(c->g, NZ_GOP_ADD, sum, term);
      if (sum < 0) break;
    }
    if (sum < 0 && (sum = nz_graph_const(c->g, 0.0)) < 0) { free(acc); acc = NULL; break; }
    acc[i] = sum;
  }
  if (acc) {
    acc[k] = out[k * k + k];
    acc[k + 1] = out[k * k + k + 1];
    c->acc_nout = checks ? k + 2 : k;
    c->acc_plan = guarded_plan(c, acc, c->acc_nout, acc + k, checks ? 2 : 0, &c->acc_guards);
    int total = c->acc_nout + nz_graph_guards_count(c->acc_guards);
    if (c->acc_plan && !(c->acc_out = malloc((size_t)total * sizeof(double)))) {
      nz_dplan_free(c->acc_plan);
      c->acc_plan = NULL;
    }
  }
  free(acc);
  free(minv);
}

int nz_recording_mass_bias_ready(nz_recording *c)
{
  if (c->mb_built) return c->mb_built > 0;
  c->mb_built = -1;
  /* Every piece that enters M and h must be compiled: F (when the system
   * has T or L pieces), V, Q; the caller (the binding) only installs this
   * hook when they are. */
  int k = c->k, nout = k * k + k + 2;
  int *out = malloc((size_t)nout * sizeof(int));
  if (!out) return 0;
  if (build_mass_bias(c, out) == 0) {
    c->mb_nout = nout;
    c->mb_plan = guarded_plan(c, out, nout, out + k * k + k, 2, &c->mb_guards);
    c->mb_in = malloc((size_t)(c->ninputs + nout + nz_graph_guards_count(c->mb_guards)) * sizeof(double));
    size_t kk = (size_t)k * (size_t)k;
    c->acc_A = malloc((kk + (size_t)k + nz_solve_spd_work_len(k)) * sizeof(double));
    if (c->mb_plan && c->mb_in && c->acc_A) {
      c->mb_out = c->mb_in + c->ninputs;
      c->acc_rhs = c->acc_A + kk;
      c->acc_work = c->acc_rhs + k;
      c->mb_built = 1;
      invert_constant_mass(c, out);
    }
  }
  free(out);
  return c->mb_built > 0;
}

/* The inputs of a plan on doubles: t, params, and slots 0 .. nfill-1 (those
 * past the state's nstate levels 0); the loops are short (k is small),
 * calls to memcpy would cost more. */
static void fill_inputs(const nz_recording *c, double *in, double t, const double *const *state,
                        int nstate, int nfill)
{
  int k = c->k;
  in[0] = t;
  for (int p = 0; p < c->np; p++) in[1 + p] = c->params[p];
  for (int j = 0; j < nfill; j++) {
    double *slot = in + nz_recording_input_slot(c, j, 0);
    if (j < nstate) memcpy(slot, state[j], (size_t)k * sizeof(double));
    else memset(slot, 0, (size_t)k * sizeof(double));
  }
}

/* t, params, q and q' (the inputs M, h and q'' read). */
static void state_inputs(const nz_recording *c, double *in, double t, const double *q, const double *qd)
{
  const double *state[2] = { q, qd };
  fill_inputs(c, in, t, state, 2, 2);
}

/* M and h at a state into c->mb_out; NZ_EARG when the graphs cannot. */
static int eval_mass_bias(nz_recording *c, double t, const double *q, const double *qd)
{
  if (!nz_recording_mass_bias_ready(c)) return NZ_EARG;
  double *in = c->mb_in;
  state_inputs(c, in, t, q, qd);
  int st = dplan_eval(c, c->mb_plan, in, c->mb_out);
  if (st) {
    /* Let the jet path run: it says which function failed, and where. */
    nz_recording_describe_failure(c, c->mb_plan->plan, st);
    return NZ_EARG;
  }
  return guards_fire(c, c->mb_guards, c->mb_out, c->mb_nout) ? NZ_EARG : NZ_OK;
}

int nz_recording_mass_bias(void *ctx, double t, const double *q, const double *qd, double *M,
                          double *h)
{
  nz_recording *c = ctx;
  int k = c->k, st = eval_mass_bias(c, t, q, qd);
  if (st) return st;
  memcpy(M, c->mb_out, (size_t)k * (size_t)k * sizeof(double));
  memcpy(h, c->mb_out + (size_t)k * (size_t)k, (size_t)k * sizeof(double));
  return NZ_OK;
}

int nz_recording_accel(void *ctx, double t, const double *q, const double *qd, double rcond_min,
                      double *qdd, nz_solve_info *info)
{
  nz_recording *c = ctx;
  int k = c->k, st;
  if (c->acc_plan) {                    /* made by mass_bias_ready */
    /* a constant M too badly conditioned: the jet path reports it */
    if (!(c->m_info.rcond >= rcond_min)) return NZ_EARG;
    /* the inputs in line (slots 0 and 1 follow t and the parameters):
     * this is the whole right-hand side of a Cartesian system, and a loop
     * over k costs less than two calls of memcpy */
    double *in = c->mb_in, *slot0 = in + 1 + c->np;
    in[0] = t;
    for (int p = 0; p < c->np; p++) in[1 + p] = c->params[p];
    for (int i = 0; i < k; i++) {
      slot0[i] = q[i];
      slot0[k + i] = qd[i];
    }
    if (c->acc_plan->nout == k) {          /* no checks: q'' is the whole output */
      if (dplan_eval(c, c->acc_plan, in, qdd) != NZ_OK) return NZ_EARG;
    } else {
      if (dplan_eval(c, c->acc_plan, in, c->acc_out) != NZ_OK) return NZ_EARG;
      if (guards_fire(c, c->acc_guards, c->acc_out, c->acc_nout)) return NZ_EARG;
      for (int i = 0; i < k; i++) qdd[i] = c->acc_out[i];
    }
    *info = c->m_info;
    return NZ_OK;
  }
  if (!nz_recording_mass_bias_ready(c)) return NZ_EARG;
  if (c->acc_plan) return nz_recording_accel(ctx, t, q, qd, rcond_min, qdd, info);   /* the first call */
  if ((st = eval_mass_bias(c, t, q, qd))) return st;
  const double *h = c->mb_out + (size_t)k * (size_t)k;
  memcpy(c->acc_A, c->mb_out, (size_t)k * (size_t)k * sizeof(double));
  for (int i = 0; i < k; i++) c->acc_rhs[i] = -h[i];
  return nz_solve_spd_in(k, c->acc_A, c->acc_rhs, qdd, rcond_min, info, c->acc_work);
}

int nz_recording_free_rhs(void *ctx, double t, const double *y, double rcond_min, double *f)
{
  nz_recording *c = ctx;
  dplan *d = c->acc_plan;
  int k = c->k;
  if (!d || !d->native || d->nout != k || !(c->m_info.rcond >= rcond_min)) return NZ_EARG;
  double *restrict in = c->mb_in, *restrict slot0 = in + 1 + c->np, *work, z = 0.0;
  in[0] = t;
  for (int p = 0; p < c->np; p++) in[1 + p] = c->params[p];
  /* slots 0 and 1 are q and q', as in y; y_i - y_i is 0 unless y_i is not
   * finite, a state the caller reports */
  for (int i = 0; i < 2 * k; i++) {
    slot0[i] = y[i];
    z += y[i] - y[i];
  }
  if (z != 0.0 || nz_native_entry(d->native, &work)(in, f + k, work)) return NZ_EARG;
  for (int i = 0; i < k; i++) f[i] = y[k + i];
  return NZ_OK;
}

/* The direction of D, the derivative along the motion: t moves by 1 and
 * slot j of q_i by slot j + 1 (none past the last slot). */
static int motion_direction(nz_recording *c, int *dir, int n)
{
  no_motion(dir, n);
  if ((dir[0] = nz_graph_const(c->g, 1.0)) < 0) return -1;
  for (int j = 0; j + 1 < c->nslots; j++)
    for (int i = 0; i < c->k; i++)
      if ((dir[nz_recording_input_slot(c, j, i)] = nz_graph_input(c->g, nz_recording_input_slot(c, j + 1, i))) < 0)
        return -1;
  return 0;
}

/* Does node root depend on an input numbered lo..hi? */
int nz_graph_reads_inputs(const nz_graph *g, int root, int lo, int hi)
{
  const nz_gnode *nd = nz_graph_nodes(g);
  char *need = calloc((size_t)root + 1, 1);
  int found = 0;
  if (!need) return 1;
  need[root] = 1;
  for (int x = root; x >= 0 && !found; x--) {
    if (!need[x]) continue;
    if (nd[x].op == NZ_GOP_INPUT) { found = nd[x].a >= lo && nd[x].a <= hi; continue; }
    if (nd[x].op == NZ_GOP_CONST) continue;
    if (nd[x].a >= 0) need[nd[x].a] = 1;
    if (nd[x].b >= 0) need[nd[x].b] = 1;
    if (nd[x].c >= 0) need[nd[x].c] = 1;
  }
  free(need);
  return found;
}

/* Outputs D^0 Phi .. D^K Phi, then dD^K Phi/dq''_i; 0 or -1.  A graph that
 * reads its last slot cannot be differentiated along the motion here. */
int nz_recording_build_row(nz_recording *c, int r, int m, int *out)
{
  int K = 2 - m, k = c->k, n = c->ninputs, ok = 1;
  int *dir = malloc((size_t)n * sizeof(int));
  if (!dir) return -1;
  out[0] = c->phi[r].nodes[0];
  if (motion_direction(c, dir, n)) ok = 0;
  /* the last slot has no slot above it: refuse a constraint that reads it */
  if (ok && nz_graph_reads_inputs(c->g, out[0], nz_recording_input_slot(c, c->nslots - 1, 0),
                         nz_recording_input_slot(c, c->nslots - 1, k - 1)))
    ok = 0;
  for (int j = 0; ok && j < K; j++)
    if ((out[j + 1] = nz_graph_derivative(c->g, out[j], dir)) < 0) ok = 0;
  for (int i = 0; ok && i < k; i++) {
    no_motion(dir, n);
    dir[nz_recording_input_slot(c, 2, i)] = nz_graph_const(c->g, 1.0);
    if ((out[K + 1 + i] = nz_graph_derivative(c->g, out[K], dir)) < 0) ok = 0;
  }
  /* The check's derivatives of Phi along slot j (j > m), weighted by
   * nz_check_slot_weight: the caller scales them by the slots' sizes. */
  for (int j = m + 1; ok && j < NZ_CONSTRAINT_SLOTS; j++) {
    no_motion(dir, n);
    for (int i = 0; i < k && ok; i++)
      if ((dir[nz_recording_input_slot(c, j, i)] = nz_graph_const(c->g, nz_check_slot_weight(j, i, k))) < 0) ok = 0;
    if (ok && (out[K + 1 + k + (j - m - 1)] = nz_graph_derivative(c->g, out[0], dir)) < 0) ok = 0;
  }
  free(dir);
  return ok ? 0 : -1;
}

int nz_recording_constraint_row(void *ctx, int r, int m, double t, const double *const *state,
                               int nstate, double alpha, double beta, double *A, double *value,
                               const double *slot_sizes, double *high)
{
  nz_recording *c = ctx;
  int k = c->k, K = 2 - m, at = 3 * r + m, nhigh = NZ_CONSTRAINT_SLOTS - 1 - m;
  if (r < 0 || r >= c->nc || m < 0 || m > 2 || !c->phi[r].n || c->nslots < NZ_CONSTRAINT_SLOTS + 2)
    return NZ_EARG;
  int nout = K + 1 + k + nhigh;
  if (!c->rows_built[at]) {
    int *out = malloc((size_t)(3 + k + NZ_CONSTRAINT_SLOTS) * sizeof(int));
    c->rows_built[at] = -1;
    /* Phi itself (output 0) is what the jets differentiate */
    if (out && nz_recording_build_row(c, r, m, out) == 0 &&
        (c->rows[at] = guarded_plan(c, out, nout, out, 1, &c->row_guards[at])) &&
        (c->row_outs[at] = malloc((size_t)(nout + nz_graph_guards_count(c->row_guards[at])) * sizeof(double))))
      c->rows_built[at] = 1;
    free(out);
  }
  if (c->rows_built[at] < 0) return NZ_EARG;
  double *in = c->row_in, *o = c->row_outs[at];
  fill_inputs(c, in, t, state, nstate, c->nslots);
  int st = dplan_eval(c, c->rows[at], in, o);
  if (st) {
    nz_recording_describe_failure(c, c->rows[at]->plan, st);
    return NZ_EARG;
  }
  if (guards_fire(c, c->row_guards[at], o, nout)) return NZ_EARG;
  *value = o[K];
  if (m == 0) *value += 2.0 * alpha * o[1] + beta * beta * o[0];
  if (m == 1) *value += alpha * o[0];
  if (A) memcpy(A, o + K + 1, (size_t)k * sizeof(double));
  if (high) {
    *high = 0.0;
    for (int j = m + 1; j < NZ_CONSTRAINT_SLOTS; j++) *high += slot_sizes[j] * o[K + 1 + k + (j - m - 1)];
  }
  return NZ_OK;
}

int nz_recording_mass_bias_nodes(const nz_recording *c)
{
  return c->mb_built > 0 ? nz_graph_plan_nodes(c->mb_plan->plan) : 0;
}

int nz_recording_mass_bias_outputs(nz_recording *c, int *out)
{
  if (!nz_recording_mass_bias_ready(c)) return NZ_EARG;
  int k = c->k;
  for (int i = 0; i < k * k + k; i++) out[i] = c->mb_plan->outs[i];
  return NZ_OK;
}

int nz_recording_piece_outputs(const nz_recording *c, nz_piece piece, int index, int *out, int max)
{
  const compiled_piece *p = piece_of(c, piece, index);
  if (!p || !p->n) return 0;
  for (int i = 0; i < p->n && i < max; i++) out[i] = p->nodes[i];
  return p->n;
}

/* Does root depend on node x?  (mark: n bytes of scratch, zeroed here) */
static int depends_on(const nz_graph *g, int root, int x, unsigned char *mark)
{
  const nz_gnode *nodes = nz_graph_nodes(g);
  memset(mark, 0, (size_t)nz_graph_size(g));
  mark[root] = 1;
  for (int y = root; y >= x; y--) {    /* operands have smaller ids */
    if (!mark[y]) continue;
    if (y == x) return 1;
    const nz_gnode *nd = &nodes[y];
    if (nd->op == NZ_GOP_CONST || nd->op == NZ_GOP_INPUT) continue;
    if (nd->a >= 0) mark[nd->a] = 1;
    if (nd->b >= 0) mark[nd->b] = 1;
    if (nd->op == NZ_GOP_SELECT && nd->c >= 0) mark[nd->c] = 1;
  }
  return 0;
}

/* Which pieces' functions hold node x: a mask of 1 << piece and, for a
 * constraint, the first one's index in *constraint. */
static unsigned pieces_holding(const nz_recording *c, int x, int *constraint, unsigned char *mark)
{
  unsigned mask = 0;
  *constraint = -1;
  for (int piece = 0; piece < NZ_PIECE_COUNT; piece++) {
    int n = piece == NZ_PIECE_PHI ? c->nc : 1;
    for (int index = 0; index < n; index++) {
      const compiled_piece *p = piece_of(c, (nz_piece)piece, index);
      for (int o = 0; p && o < p->n; o++)
        if (depends_on(c->g, p->nodes[o], x, mark)) {
          mask |= 1u << piece;
          if (piece == NZ_PIECE_PHI && *constraint < 0) *constraint = index;
          break;
        }
    }
  }
  return mask;
}

int nz_recording_rounding_branch(nz_recording *c, double t, const double *const *state, int nstate, double tol,
                                nz_rounding_branch *out, unsigned *pieces, int *constraint)
{
  int k = c->k, n = nz_graph_size(c->g), nroots = 0;
  int *roots = malloc(((size_t)k * (size_t)k + (size_t)k + (size_t)n) * sizeof(int) + 1);
  double *in = calloc((size_t)c->ninputs + 1, sizeof(double));
  unsigned char *mark = malloc((size_t)n + 1);
  int found = -1;
  if (roots && in && mark) {
    if (nz_recording_mass_bias_ready(c))                     /* M and h: what the integrators evaluate */
      for (int i = 0; i < k * k + k; i++) roots[nroots++] = c->mb_plan->outs[i];
    for (int piece = 0; piece < NZ_PIECE_COUNT; piece++)
      for (int index = 0; index < (piece == NZ_PIECE_PHI ? c->nc : 1); index++) {
        const compiled_piece *p = piece_of(c, (nz_piece)piece, index);
        for (int o = 0; p && o < p->n && nroots < k * k + k + n; o++) roots[nroots++] = p->nodes[o];
      }
    fill_inputs(c, in, t, state, nstate, c->nslots);
    found = nz_graph_rounding_branch(c->g, roots, nroots, in, tol, out);
    /* the pieces whose functions hold the branch itself; a branch only M
     * and h hold (sign from abs's derivative) is named by its operand's */
    if (found == 1 && !(*pieces = pieces_holding(c, out->node, constraint, mark)))
      *pieces = pieces_holding(c, out->decider, constraint, mark);
  }
  free(roots);
  free(in);
  free(mark);
  return found;
}
