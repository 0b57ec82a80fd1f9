/* mech_graph.c - a system's recorded pieces behind nz_evaluator, and the
 * mass matrix and bias derived from them (mech_graph.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "graph/graph_guard.h"
#include "graph/graph_native.h"
#include "graph/series_native.h"
#include "jets/series.h"
#include "core/linalg.h"
#include "mech/mech_graph.h"
#include "graph/graph_rounding.h"

/* A plan on doubles that runs as machine code (graph_native.h): in auto
 * mode its compile starts in the background once interpreting it has cost
 * a sixteenth of what compiling would (start, below) and the plan switches
 * to the object when it is ready, between two evaluations (the results are
 * the same bit for bit); at once when its object is cached; at its first
 * use, waiting for the compiler, with native on; never with native off or
 * when compiling fails (the reason is kept for graph_info). */
typedef struct dplan {
  nz_graph_plan *plan;
  int *outs, nout;
  nz_native *native;      /* the loaded object (NULL: interpreted) */
  nz_native *compiling;   /* a compile under way in the background */
  double work;            /* nodes interpreted so far */
  double start;           /* ... before its compile starts (auto mode) */
  unsigned polls;         /* evaluations since the compile was last polled */
  int tried, used;
  /* The plan's series (Taylor's method) as machine code, on the same
   * policy: node coefficients interpreted so far, whether it was tried. */
  nz_series_native *ser, *ser_compiling;
  double ser_work;
  int ser_tried, ser_looked, ser_used;
} dplan;

typedef struct compiled_piece {
  int n;                  /* outputs: 0 when the piece is not compiled */
  int *nodes;
  nz_graph_plan *plan;
} compiled_piece;

struct nz_compiled {
  int k, np, nc, nslots, ninputs;
  nz_graph *g;
  double *params;                      /* np current values */
  compiled_piece piece[NZ_PIECE_COUNT];   /* PHI unused: see phi */
  compiled_piece *phi;                 /* nc constraints */
  /* Evaluation scratch, sized once: input pointers and parameter jets. */
  const nz_jet **in, **din;
  nz_jet **pjet;                       /* np constant jets of order pcap */
  int pcap;
  /* Mass and bias on doubles (built on first use; built = -1 if impossible);
   * the guards read the plan's outputs after its own mb_nout
   * (graph_guard.h: ties and singular points go to the jets). */
  int mb_built, mb_nout;
  dplan *mb_plan;
  nz_graph_guards *mb_guards;
  double *mb_in, *mb_out;
  /* Native code: mode (-1 auto, 0 off, 1 on), plans compiled, seconds
   * compiling took and how many of them runs waited, why the last attempt
   * failed; plans (and series) evaluated so far and how many of those run
   * as machine code, compiles under way. */
  int native_mode, native_count, native_series;
  double native_seconds, native_waited;
  char native_why[300];
  int plans_used, plans_native, series_used, series_native, compiling;
  /* nz_compiled_accel's workspace: A (k x k), rhs (k), the solver's. */
  double *acc_A, *acc_rhs, *acc_work;
  /* With a constant M, q'' = -M^-1 h as a plan of its own (M^-1's entries
   * are constants of the graph), and F, V checked: one pass per call;
   * m_info is the solve info of the one factorization of M. */
  dplan *acc_plan;
  nz_graph_guards *acc_guards;
  int acc_nout;
  nz_solve_info m_info;
  double *acc_out;
  /* Constraint rows on doubles: plan of (r, m) at rows[3 r + m] (built = 1,
   * or -1 when it cannot be built), outputs D^0..D^K Phi then A. */
  dplan **rows;
  signed char *rows_built;
  nz_graph_guards **row_guards;
  double **row_outs;                   /* each row plan's outputs, guards' after */
  double *row_in;
  /* nz_compiled_motion_series's workspace, for series up to ts_cap + 1
   * coefficients of q (grown, never shrunk): the inputs' coefficient
   * (ninputs), M_0's factor and the solver's work, a right-hand side (k),
   * q''s coefficients ((ts_cap - 1) k), and the series of M's entries. */
  int ts_cap;
  double *ts_in, *ts_L, *ts_work, *ts_rhs, *ts_qdd;
  const double **ts_M;
  double **ts_inp;   /* the plan's input series, written in place (ninputs) */
  struct cseries *cs;   /* nz_compiled_constrained_series's plans and workspace */
  int *ts_pos;       /* input numbers of q_i, of q_i', output numbers of q_i'' (3k) */
  char failure[160];
};

static void dplan_free(dplan *d)
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

static dplan *dplan_new(const nz_graph *g, const int *outs, int n)
{
  dplan *d = calloc(1, sizeof *d);
  if (!d) return NULL;
  d->outs = malloc((size_t)n * sizeof(int));
  d->plan = nz_graph_plan_new(g, outs, n);
  if (!d->outs || !d->plan) { dplan_free(d); return NULL; }
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
static int cache_dir(nz_compiled *c, char *dir, size_t n)
{
  char why[300];
  if (nz_native_cache_dir(dir, n, why, sizeof why)) return 1;
  snprintf(c->native_why, sizeof c->native_why, "%s", why);
  return 0;
}

/* A plan whose object is already in the cache runs natively at once
 * (auto and on; loading costs microseconds per node).  An untrusted cache
 * says why. */
static void dplan_load_cached(nz_compiled *c, dplan *d)
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
static void dplan_switch(nz_compiled *c, dplan *d, nz_native *f)
{
  d->native = f;
  c->native_count++;
  c->native_seconds += nz_native_compile_seconds(f);
  c->native_waited += nz_native_waited(f);
  if (d->used) c->plans_native++;
}

/* Compile d: in the background (auto mode), or now, waiting (native on). */
static void dplan_compile(nz_compiled *c, dplan *d, int wait)
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
static void dplan_poll(nz_compiled *c, dplan *d, int wait)
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
static void dplan_series_poll(nz_compiled *c, dplan *d, int wait)
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
static void dplan_series_native(nz_compiled *c, dplan *d, int N, const nz_series_ode2 *ode2)
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
static inline nz_status dplan_eval(nz_compiled *c, dplan *d, const double *in, double *out)
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
int nz_compiled_all_native(void *ctx)
{
  const nz_compiled *c = ctx;
  if (c->native_mode == 0) return -1;
  return c->plans_used == c->plans_native && c->series_used == c->series_native;
}

/* Wait for every compile under way. */
void nz_compiled_native_wait(nz_compiled *c)
{
  dplan *all[2] = { c->mb_plan, c->acc_plan };
  for (int i = 0; i < 2; i++)
    if (all[i] && all[i]->compiling) dplan_poll(c, all[i], 1);
  for (int r = 0; c->rows && r < 3 * c->nc; r++)
    if (c->rows[r] && c->rows[r]->compiling) dplan_poll(c, c->rows[r], 1);
  for (int i = 0; i < 2; i++)
    if (all[i] && all[i]->ser_compiling) dplan_series_poll(c, all[i], 1);
}

int nz_compiled_native_compiling(const nz_compiled *c) { return c->compiling; }
int nz_compiled_native_mode(const nz_compiled *c) { return c->native_mode; }
double nz_compiled_native_waited(const nz_compiled *c) { return c->native_waited; }

int nz_compiled_native_series(const nz_compiled *c) { return c->native_series; }

void nz_compiled_set_native(nz_compiled *c, int mode) { c->native_mode = mode < 0 ? -1 : mode > 0; }

int nz_compiled_native(const nz_compiled *c, double *seconds, const char **why)
{
  if (seconds) *seconds = c->native_seconds;
  if (why) *why = c->native_why[0] ? c->native_why : NULL;
  return c->native_count;
}

nz_compiled *nz_compiled_new(int k, int np, int nc, int nslots)
{
  if (k < 1 || np < 0 || nc < 0) return NULL;
  if (nslots < 2) nslots = 2;
  nz_compiled *c = calloc(1, sizeof *c);
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
    nz_compiled_free(c);
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

static void constrained_series_free(nz_compiled *c);   /* at the end of this file */

void nz_compiled_free(nz_compiled *c)
{
  if (!c) return;
  for (int p = 0; p < NZ_PIECE_COUNT; p++) piece_clear(&c->piece[p]);
  for (int r = 0; c->phi && r < c->nc; r++) piece_clear(&c->phi[r]);
  for (int p = 0; c->pjet && p < c->np; p++) nz_jet_free(c->pjet[p]);
  dplan_free(c->mb_plan);
  dplan_free(c->acc_plan);
  nz_graph_guards_free(c->mb_guards);
  nz_graph_guards_free(c->acc_guards);
  free(c->acc_out);
  for (int r = 0; c->rows && r < 3 * c->nc; r++) dplan_free(c->rows[r]);
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
  constrained_series_free(c);
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

nz_graph *nz_compiled_graph(nz_compiled *c) { return c->g; }
double *nz_compiled_params(nz_compiled *c) { return c->params; }
int nz_compiled_nparams(const nz_compiled *c) { return c->np; }
const char *nz_compiled_failure(const nz_compiled *c) { return c->failure; }

int nz_compiled_input_slot(const nz_compiled *c, int j, int i)
{
  return 1 + c->np + j * c->k + i;
}

int nz_compiled_input_frozen(const nz_compiled *c, int i) { return 1 + c->np + c->nslots * c->k + i; }
int nz_compiled_nslots(const nz_compiled *c) { return c->nslots; }
int nz_compiled_ncoords(const nz_compiled *c) { return c->k; }

static compiled_piece *piece_of(const nz_compiled *c, nz_piece piece, int index)
{
  if (piece == NZ_PIECE_PHI) return index >= 0 && index < c->nc ? &c->phi[index] : NULL;
  return piece >= 0 && piece < NZ_PIECE_COUNT ? (compiled_piece *)&c->piece[piece] : NULL;
}

int nz_compiled_set_piece(nz_compiled *c, nz_piece piece, int index, const int *nodes, int n)
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

int nz_compiled_has(const nz_compiled *c, nz_piece piece, int index)
{
  const compiled_piece *p = piece_of(c, piece, index);
  return p && p->n > 0;
}

int nz_compiled_piece_nodes(const nz_compiled *c, nz_piece piece, int index)
{
  const compiled_piece *p = piece_of(c, piece, index);
  return p && p->n > 0 ? nz_graph_plan_nodes(p->plan) : 0;
}

/* The parameters as constant jets of (at least) this order. */
static int param_jets(nz_compiled *c, int order)
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

static void describe_failure(nz_compiled *c, const nz_graph_plan *plan, int st)
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

int nz_compiled_eval(void *ctx, nz_piece piece, int index, const nz_jet *t,
                     nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
                     const nz_direction *dir)
{
  nz_compiled *c = ctx;
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
      int at = nz_compiled_input_slot(c, j, i);
      c->in[at] = j < nlevels ? levels[j][i] : NULL;
      c->din[at] = dir && j < nlevels ? dir->dlevels[j][i] : NULL;
    }
  st = nz_graph_eval_jets(p->plan, c->in, out, dir ? c->din : NULL, dir ? dir->dout : NULL);
  if (st) describe_failure(c, p->plan, st);
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
static int build_mass_bias(nz_compiled *c, int *out)
{
  nz_graph *g = c->g;
  int k = c->k, n = c->ninputs;   /* nz_compiled_set_piece keeps the graph's inputs within */
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
      dir[nz_compiled_input_slot(c, s, i)] = one;
      int d = nz_graph_derivative(g, F, dir);
      if (d < 0) ok = 0;
      else (s ? gqd : gq)[i] = d;
    }
  /* M_ij = d(dF/dq'_i)/dq'_j */
  for (int j = 0; ok && j < k; j++) {
    no_motion(dir, n);
    dir[nz_compiled_input_slot(c, 1, j)] = one;
    if (nz_graph_derivatives(g, gqd, k, dir, tmp)) ok = 0;
    for (int i = 0; ok && i < k; i++) out[i * k + j] = tmp[i];
  }
  /* d/dt (dF/dq'_i) with q'' = 0: along t -> 1, q -> q' */
  if (ok) {
    no_motion(dir, n);
    dir[0] = one;
    for (int j = 0; j < k; j++) dir[nz_compiled_input_slot(c, 1, j)] = -1;
    for (int j = 0; j < k && ok; j++)
      if ((dir[nz_compiled_input_slot(c, 0, j)] = nz_graph_input(g, nz_compiled_input_slot(c, 1, j))) < 0)
        ok = 0;
    if (ok && nz_graph_derivatives(g, gqd, k, dir, tmp)) ok = 0;
  }
  /* h = d/dt dF/dq' - dF/dq + dV/dq - Q */
  int V = c->piece[NZ_PIECE_V].n ? c->piece[NZ_PIECE_V].nodes[0] : -1;
  for (int i = 0; ok && i < k; i++) {
    int h = nz_graph_op(g, NZ_GOP_SUB, tmp[i], gq[i]);
    if (V >= 0 && h >= 0) {
      no_motion(dir, n);
      dir[nz_compiled_input_slot(c, 0, i)] = one;
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
static dplan *guarded_plan(nz_compiled *c, const int *out, int n, const int *smooth, int nsmooth,
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
  dplan *d = dplan_new(c->g, all, n + ng);
  free(all);
  if (d) dplan_load_cached(c, d);
  return d;
}

/* After a plan's evaluation: does it meet a tie or a singular point that
 * the jets must decide (vals: its outputs, the guards' after its own n)? */
static int guards_fire(nz_compiled *c, const nz_graph_guards *gd, const double *vals, int n)
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
static void invert_constant_mass(nz_compiled *c, const int *out)
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
      dplan_free(c->acc_plan);
      c->acc_plan = NULL;
    }
  }
  free(acc);
  free(minv);
}

static int mass_bias_ready(nz_compiled *c)
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
static void fill_inputs(const nz_compiled *c, double *in, double t, const double *const *state,
                        int nstate, int nfill)
{
  int k = c->k;
  in[0] = t;
  for (int p = 0; p < c->np; p++) in[1 + p] = c->params[p];
  for (int j = 0; j < nfill; j++) {
    double *slot = in + nz_compiled_input_slot(c, j, 0);
    if (j < nstate) memcpy(slot, state[j], (size_t)k * sizeof(double));
    else memset(slot, 0, (size_t)k * sizeof(double));
  }
}

/* t, params, q and q' (the inputs M, h and q'' read). */
static void state_inputs(const nz_compiled *c, double *in, double t, const double *q, const double *qd)
{
  const double *state[2] = { q, qd };
  fill_inputs(c, in, t, state, 2, 2);
}

/* M and h at a state into c->mb_out; NZ_EARG when the graphs cannot. */
static int eval_mass_bias(nz_compiled *c, double t, const double *q, const double *qd)
{
  if (!mass_bias_ready(c)) return NZ_EARG;
  double *in = c->mb_in;
  state_inputs(c, in, t, q, qd);
  int st = dplan_eval(c, c->mb_plan, in, c->mb_out);
  if (st) {
    /* Let the jet path run: it says which function failed, and where. */
    describe_failure(c, c->mb_plan->plan, st);
    return NZ_EARG;
  }
  return guards_fire(c, c->mb_guards, c->mb_out, c->mb_nout) ? NZ_EARG : NZ_OK;
}

int nz_compiled_mass_bias(void *ctx, double t, const double *q, const double *qd, double *M,
                          double *h)
{
  nz_compiled *c = ctx;
  int k = c->k, st = eval_mass_bias(c, t, q, qd);
  if (st) return st;
  memcpy(M, c->mb_out, (size_t)k * (size_t)k * sizeof(double));
  memcpy(h, c->mb_out + (size_t)k * (size_t)k, (size_t)k * sizeof(double));
  return NZ_OK;
}

int nz_compiled_accel(void *ctx, double t, const double *q, const double *qd, double rcond_min,
                      double *qdd, nz_solve_info *info)
{
  nz_compiled *c = ctx;
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
  if (!mass_bias_ready(c)) return NZ_EARG;
  if (c->acc_plan) return nz_compiled_accel(ctx, t, q, qd, rcond_min, qdd, info);   /* the first call */
  if ((st = eval_mass_bias(c, t, q, qd))) return st;
  const double *h = c->mb_out + (size_t)k * (size_t)k;
  memcpy(c->acc_A, c->mb_out, (size_t)k * (size_t)k * sizeof(double));
  for (int i = 0; i < k; i++) c->acc_rhs[i] = -h[i];
  return nz_solve_spd_in(k, c->acc_A, c->acc_rhs, qdd, rcond_min, info, c->acc_work);
}

int nz_compiled_free_rhs(void *ctx, double t, const double *y, double rcond_min, double *f)
{
  nz_compiled *c = ctx;
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
static int motion_direction(nz_compiled *c, int *dir, int n)
{
  no_motion(dir, n);
  if ((dir[0] = nz_graph_const(c->g, 1.0)) < 0) return -1;
  for (int j = 0; j + 1 < c->nslots; j++)
    for (int i = 0; i < c->k; i++)
      if ((dir[nz_compiled_input_slot(c, j, i)] = nz_graph_input(c->g, nz_compiled_input_slot(c, j + 1, i))) < 0)
        return -1;
  return 0;
}

/* Does node root depend on an input numbered lo..hi? */
static int reads_inputs(const nz_graph *g, int root, int lo, int hi)
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
static int build_row(nz_compiled *c, int r, int m, int *out)
{
  int K = 2 - m, k = c->k, n = c->ninputs, ok = 1;
  int *dir = malloc((size_t)n * sizeof(int));
  if (!dir) return -1;
  out[0] = c->phi[r].nodes[0];
  if (motion_direction(c, dir, n)) ok = 0;
  /* the last slot has no slot above it: refuse a constraint that reads it */
  if (ok && reads_inputs(c->g, out[0], nz_compiled_input_slot(c, c->nslots - 1, 0),
                         nz_compiled_input_slot(c, c->nslots - 1, k - 1)))
    ok = 0;
  for (int j = 0; ok && j < K; j++)
    if ((out[j + 1] = nz_graph_derivative(c->g, out[j], dir)) < 0) ok = 0;
  for (int i = 0; ok && i < k; i++) {
    no_motion(dir, n);
    dir[nz_compiled_input_slot(c, 2, i)] = nz_graph_const(c->g, 1.0);
    if ((out[K + 1 + i] = nz_graph_derivative(c->g, out[K], dir)) < 0) ok = 0;
  }
  /* The check's derivatives of Phi along slot j (j > m), weighted by
   * nz_check_slot_weight: the caller scales them by the slots' sizes. */
  for (int j = m + 1; ok && j < NZ_CONSTRAINT_SLOTS; j++) {
    no_motion(dir, n);
    for (int i = 0; i < k && ok; i++)
      if ((dir[nz_compiled_input_slot(c, j, i)] = nz_graph_const(c->g, nz_check_slot_weight(j, i, k))) < 0) ok = 0;
    if (ok && (out[K + 1 + k + (j - m - 1)] = nz_graph_derivative(c->g, out[0], dir)) < 0) ok = 0;
  }
  free(dir);
  return ok ? 0 : -1;
}

int nz_compiled_constraint_row(void *ctx, int r, int m, double t, const double *const *state,
                               int nstate, double alpha, double beta, double *A, double *value,
                               const double *slot_sizes, double *high)
{
  nz_compiled *c = ctx;
  int k = c->k, K = 2 - m, at = 3 * r + m, nhigh = NZ_CONSTRAINT_SLOTS - 1 - m;
  if (r < 0 || r >= c->nc || m < 0 || m > 2 || !c->phi[r].n || c->nslots < NZ_CONSTRAINT_SLOTS + 2)
    return NZ_EARG;
  int nout = K + 1 + k + nhigh;
  if (!c->rows_built[at]) {
    int *out = malloc((size_t)(3 + k + NZ_CONSTRAINT_SLOTS) * sizeof(int));
    c->rows_built[at] = -1;
    /* Phi itself (output 0) is what the jets differentiate */
    if (out && build_row(c, r, m, out) == 0 &&
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
    describe_failure(c, c->rows[at]->plan, st);
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

int nz_compiled_mass_bias_nodes(const nz_compiled *c)
{
  return c->mb_built > 0 ? nz_graph_plan_nodes(c->mb_plan->plan) : 0;
}

int nz_compiled_mass_bias_outputs(nz_compiled *c, int *out)
{
  if (!mass_bias_ready(c)) return NZ_EARG;
  int k = c->k;
  for (int i = 0; i < k * k + k; i++) out[i] = c->mb_plan->outs[i];
  return NZ_OK;
}

int nz_compiled_piece_outputs(const nz_compiled *c, nz_piece piece, int index, int *out, int max)
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
static unsigned pieces_holding(const nz_compiled *c, int x, int *constraint, unsigned char *mark)
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

int nz_compiled_rounding_branch(nz_compiled *c, double t, const double *const *state, int nstate, double tol,
                                nz_rounding_branch *out, unsigned *pieces, int *constraint)
{
  int k = c->k, n = nz_graph_size(c->g), nroots = 0;
  int *roots = malloc(((size_t)k * (size_t)k + (size_t)k + (size_t)n) * sizeof(int) + 1);
  double *in = calloc((size_t)c->ninputs + 1, sizeof(double));
  unsigned char *mark = malloc((size_t)n + 1);
  int found = -1;
  if (roots && in && mark) {
    if (mass_bias_ready(c))                     /* M and h: what the integrators evaluate */
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

/* ------------------------------------------------------------------ */
/* The series of the motion (Taylor's method)                           */

/* The workspace of nz_compiled_motion_series for p + 1 coefficients. */
static int series_workspace(nz_compiled *c, int p)
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
    pos[i] = nz_compiled_input_slot(c, 0, i);
    pos[k + (size_t)i] = nz_compiled_input_slot(c, 1, i);
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
static void series_inputs_at(const nz_compiled *c, double *in, int n, double t0, const double *a)
{
  int k = c->k;
  in[0] = n == 0 ? t0 : n == 1 ? 1.0 : 0.0;
  for (int p = 0; p < c->np; p++) in[1 + p] = n == 0 ? c->params[p] : 0.0;
  double *s0 = in + nz_compiled_input_slot(c, 0, 0), *s1 = s0 + k;
  const double *an = a + (size_t)n * (size_t)k, *an1 = an + k;
  for (int i = 0; i < k; i++) {
    s0[i] = an[i];
    s1[i] = (n + 1) * an1[i];
  }
}

/* The same for n >= 1, written in place into the plan's input series
 * (nz_graph_series_inputs; NULL: an input the plan does not read). */
static void series_inputs_put(const nz_compiled *c, double *const *ip, int n, const double *a)
{
  int k = c->k, s0 = nz_compiled_input_slot(c, 0, 0);
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

int nz_compiled_motion_series(nz_compiled *c, double t0, const double *q0, const double *qd0, int p,
                              double *a)
{
  int k = c->k, st;
  if (p < 0 || p > NZ_JET_MAX_ORDER + 2) return NZ_EDOM;
  if (!mass_bias_ready(c)) return NZ_EARG;
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
   * nz_compiled_failure names it. */
  if ((st = nz_graph_series_begin(plan, N, in))) goto fail;
  if (constant) {
    /* q'' = -M^-1 h as a second-order ODE on the plan: its machine code
     * runs the whole series in one loop */
    nz_series_ode2 o = { k, 0, c->ts_pos, c->ts_pos + k, c->ts_pos + 2 * k };
    dplan_series_native(c, c->acc_plan, N, &o);
    if (c->acc_plan->ser && nz_series_native_ode2(c->acc_plan->ser, plan, N, a) == 0) return NZ_OK;
  } else
    dplan_series_native(c, c->mb_plan, N, NULL);
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
  describe_failure(c, plan, st);
  return st;
}

int nz_compiled_motion_branches(nz_compiled *c)
{
  if (!mass_bias_ready(c)) return -1;
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
    if (w->plan) dplan_free(w->plan[r]);
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

static void constrained_series_free(nz_compiled *c)
{
  cseries_free(c->cs);
  c->cs = NULL;
}

/* The plans of Phi_r and A_r for the orders m[r]: NZ_OK, or NZ_EARG with
 * the reason in c->failure (a constraint not recorded, of order > 2, or
 * reading a derivative above its order: its series would need coefficients
 * of q not known yet). */
static int cseries_plans(nz_compiled *c, const int *m)
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
    } else if (m[r] < 2 && reads_inputs(c->g, c->phi[r].nodes[0], nz_compiled_input_slot(c, m[r] + 1, 0),
                                        nz_compiled_input_slot(c, c->nslots - 1, k - 1))) {
      snprintf(c->failure, sizeof c->failure,
               "constraint %d is of order %d but its function reads higher derivatives of q", r + 1, m[r]);
      st = NZ_EARG;
    } else if (build_row(c, r, m[r], out)) {
      snprintf(c->failure, sizeof c->failure, "constraint %d: its gradient could not be built on the graph", r + 1);
      st = NZ_EARG;
    } else {
      po[0] = out[0];
      memcpy(po + 1, out + (2 - m[r]) + 1, (size_t)k * sizeof(int));
      if (!(w->plan[r] = dplan_new(c->g, po, k + 1)) ||
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
static int cseries_workspace(nz_compiled *c, int N)
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
static void cseries_put(const nz_compiled *c, double *const *ip, int j, double t0, const double *a, int top)
{
  int k = c->k;
  if (ip[0]) ip[0][j] = j == 0 ? t0 : j == 1 ? 1.0 : 0.0;
  for (int p = 0; p < c->np; p++)
    if (ip[1 + p]) ip[1 + p][j] = j == 0 ? c->params[p] : 0.0;
  for (int s = 0; s < c->nslots; s++)
    for (int i = 0; i < k; i++) {
      double *x = ip[nz_compiled_input_slot(c, s, i)];
      if (x) x[j] = s <= 2 ? slot_coef(a, k, i, s, j, top) : 0.0;
    }
}

int nz_compiled_constrained_series(nz_compiled *c, const int *orders, double t0, const double *q0,
                                   const double *qd0, const double *qdd0, const double *lam0, int p, double *a,
                                   double *lambda)
{
  return nz_compiled_constrained_series_sel(c, orders, NULL, t0, q0, qd0, qdd0, lam0, p, a, lambda);
}

int nz_compiled_series(void *ctx, const int *orders, const nz_series_selection *sel, double t0, const double *q0,
                       const double *qd0, const double *qdd0, const double *lam0, int p, double *a)
{
  if (!orders) return nz_compiled_motion_series(ctx, t0, q0, qd0, p, a);
  return nz_compiled_constrained_series_sel(ctx, orders, sel, t0, q0, qd0, qdd0, lam0, p, a, NULL);
}

int nz_compiled_constrained_series_sel(nz_compiled *c, const int *orders, const nz_series_selection *sel, double t0,
                                       const double *q0, const double *qd0, const double *qdd0, const double *lam0,
                                       int p, double *a, double *lambda)
{
  int k = c->k, st;
  /* the rows held: every constraint, or the selection's (a contact mode);
   * row x is constraint R(x), and its force rides on a second row D(x)
   * with the coefficient CF(x) (a sliding contact's friction) */
  int na = sel ? sel->n : c->nc;
#define R(x) (sel ? sel->rows[x] : (x))
#define D(x) (sel && sel->couple ? sel->couple[x] : -1)
#define CF(x) (sel && sel->coef ? sel->coef[x] : 0.0)
  if (p < 2 || p > NZ_JET_MAX_ORDER) return NZ_EDOM;
  if (na < 0 || na > c->nc) return NZ_EARG;
  if (!mass_bias_ready(c)) return NZ_EARG;
  if ((st = cseries_plans(c, orders))) return st;
  int N = p - 2;   /* q'''s coefficients 0 .. N give a_2 .. a_p */
  if ((st = cseries_workspace(c, N))) return st;
  cseries *w = c->cs;
  nz_graph_plan *mb = c->mb_plan->plan;
  memcpy(a, q0, (size_t)k * sizeof(double));
  memcpy(a + k, qd0, (size_t)k * sizeof(double));
  for (int i = 0; i < k; i++) a[2 * k + i] = qdd0[i] * 0.5;
  memcpy(w->qdd, qdd0, (size_t)k * sizeof(double));
  memcpy(w->lam, lam0, (size_t)na * sizeof(double));
  /* coefficient 0 of every plan; the constraint plans then up to their
   * coefficient 2 - m, the one order 0 settled */
  double *in = w->in0;
  memset(in, 0, (size_t)c->ninputs * sizeof(double));
  in[0] = t0;
  for (int q = 0; q < c->np; q++) in[1 + q] = c->params[q];
  for (int i = 0; i < k; i++) {
    in[nz_compiled_input_slot(c, 0, i)] = q0[i];
    in[nz_compiled_input_slot(c, 1, i)] = qd0[i];
    in[nz_compiled_input_slot(c, 2, i)] = qdd0[i];
  }
  nz_graph_plan *fail_plan = mb;
  if ((st = nz_graph_series_begin(mb, N, in))) goto fail;
  nz_graph_series_inputs(mb, w->mb_inp, c->ninputs);
  for (int e = 0; e < k * k; e++)
    if (!(w->Mser[e] = nz_graph_series_node(mb, c->mb_plan->outs[e]))) return NZ_EARG;
  for (int x = 0; x < na; x++)
    for (int pass = 0; pass < 2; pass++) {   /* the row, then the row its force rides on */
      int r = pass ? D(x) : R(x);
      if (r < 0) continue;
      nz_graph_plan *pr = w->plan[r]->plan;
      fail_plan = pr;
      if ((st = nz_graph_series_begin(pr, N + 2, in))) goto fail;
      nz_graph_series_inputs(pr, w->inp[r], c->ninputs);
      w->phi[r] = nz_graph_series_node(pr, w->plan[r]->outs[0]);
      for (int i = 0; i < k; i++) w->Aser[r * k + i] = nz_graph_series_node(pr, w->plan[r]->outs[1 + i]);
      for (int j = 1; !pass && j <= 2 - orders[r]; j++) {
        cseries_put(c, w->inp[r], j, t0, a, 2);
        if ((st = nz_graph_series_next(pr, j, NULL, NULL))) goto fail;
      }
    }
  /* The saddle-point matrix of every order n >= 1, [M_0 - sum lambda0_r
   * H_r, -W_0^T; A_0, 0], H_r = dA_r/dq'' (zero unless constraint r is of
   * order 2 and not linear in q''), W the forces' rows (A, or A + CF D),
   * factored once. */
  int n2 = k + na;
  double *S = w->S, *H = w->H;
  memset(H, 0, (size_t)k * (size_t)k * (size_t)c->nc * sizeof(double));
  if (N >= 1)
    for (int x = 0; x < na; x++) {
      int r = R(x);
      if (orders[r] != 2) continue;
      /* dA_r/dq'' by probing coefficient 1: it is affine in q''_1 with that
       * slope (the chain rule of the top coefficient), exactly */
      nz_graph_plan *pr = w->plan[r]->plan;
      fail_plan = pr;
      double *base = w->rhs;   /* free until the loop below */
      cseries_put(c, w->inp[r], 1, t0, a, 2);
      if ((st = nz_graph_series_next(pr, 1, NULL, NULL))) goto fail;
      for (int i = 0; i < k; i++) base[i] = w->Aser[r * k + i][1];
      for (int j = 0; j < k; j++) {
        double *xin = w->inp[r][nz_compiled_input_slot(c, 2, j)];
        if (!xin) continue;   /* A_r does not read q''_j */
        xin[1] = 1.0;
        if ((st = nz_graph_series_next(pr, 1, NULL, NULL))) goto fail;
        for (int i = 0; i < k; i++)
          H[((size_t)x * (size_t)k + (size_t)i) * (size_t)k + (size_t)j] = w->Aser[r * k + i][1] - base[i];
        xin[1] = 0.0;
      }
    }
  for (int i = 0; i < k; i++) {
    for (int j = 0; j < k; j++) {
      double v = w->Mser[i * k + j][0];
      for (int x = 0; x < na; x++) v -= lam0[x] * H[((size_t)x * (size_t)k + (size_t)i) * (size_t)k + (size_t)j];
      S[(size_t)i * (size_t)n2 + (size_t)j] = v;
    }
    for (int x = 0; x < na; x++) {
      double f = w->Aser[R(x) * k + i][0];
      if (D(x) >= 0) f += CF(x) * w->Aser[D(x) * k + i][0];
      S[(size_t)i * (size_t)n2 + (size_t)(k + x)] = -f;
    }
  }
  for (int x = 0; x < na; x++) {
    for (int j = 0; j < k; j++) S[(size_t)(k + x) * (size_t)n2 + (size_t)j] = w->Aser[R(x) * k + j][0];
    for (int j = 0; j < na; j++) S[(size_t)(k + x) * (size_t)n2 + (size_t)(k + j)] = 0.0;
  }
  if (N >= 1 && (st = nz_lu_factor(w->lu, n2, S))) {
    snprintf(c->failure, sizeof c->failure, "the saddle-point matrix [M A^T; A 0] is singular");
    return st;
  }
  for (int n = 1; n <= N; n++) {
    /* coefficient n of M and h: q to a_{n+1}, known */
    fail_plan = mb;
    cseries_put(c, w->mb_inp, n, t0, a, n + 1);
    if ((st = nz_graph_series_next(mb, n, NULL, NULL))) goto fail;
    double *u = w->rhs;
    for (int i = 0; i < k; i++) {
      double s = nz_graph_series_coef(mb, k * k + i, n);   /* h_i */
      for (int j = 1; j <= n; j++)
        for (int x = 0; x < k; x++) s += w->Mser[i * k + x][j] * w->qdd[(size_t)(n - j) * (size_t)k + (size_t)x];
      u[i] = -s;
    }
    /* the constraints: coefficient n + 2 - m of Phi_r with q''_n = 0 ... */
    for (int x = 0; x < na; x++) {
      int r = R(x), m = orders[r], j = n + 2 - m, d = D(x);
      nz_graph_plan *pr = w->plan[r]->plan;
      fail_plan = pr;
      cseries_put(c, w->inp[r], j, t0, a, n + 1);
      if ((st = nz_graph_series_next(pr, j, NULL, NULL))) goto fail;
      /* ... is affine in q''_n with slope A_r0 times (slot m's coefficient
       * j per unit of q''_n): 1 / ((n+1)(n+2)), 1 / (n+1), 1, so that
       * dividing by it is multiplying by an integer (one rounding, no bias) */
      double per = m == 0 ? (double)(n + 1) * (double)(n + 2) : m == 1 ? (double)(n + 1) : 1.0;
      u[k + x] = -w->phi[r][j] * per;
      if (d >= 0) {
        /* the row the force rides on, to its coefficient n: it reads q and
         * q' at most (order <= 1), known to a_{n+1} */
        nz_graph_plan *pd = w->plan[d]->plan;
        fail_plan = pd;
        cseries_put(c, w->inp[d], n, t0, a, n + 1);
        if ((st = nz_graph_series_next(pd, n, NULL, NULL))) goto fail;
      }
      /* W^T lambda's coefficient n without W_0^T lambda_n (in the matrix):
       * sum_{i=1..n} W_i^T lambda_{n-i}, A_n at q''_n = 0 (its part in
       * q''_n is the matrix's H) */
      for (int y = 0; y < k; y++) {
        double s = 0.0;
        for (int i = 1; i <= n; i++) {
          double f = w->Aser[r * k + y][i];
          if (d >= 0) f += CF(x) * w->Aser[d * k + y][i];
          s += f * w->lam[(size_t)(n - i) * (size_t)na + (size_t)x];
        }
        u[y] += s;
      }
    }
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
    /* the constraint plans' coefficient n + 2 - m again, with q''_n */
    for (int x = 0; x < na; x++) {
      int r = R(x), j = n + 2 - orders[r];
      nz_graph_plan *pr = w->plan[r]->plan;
      fail_plan = pr;
      cseries_put(c, w->inp[r], j, t0, a, n + 2);
      if ((st = nz_graph_series_next(pr, j, NULL, NULL))) goto fail;
    }
  }
  if (lambda) memcpy(lambda, w->lam, (size_t)(N + 1) * (size_t)na * sizeof(double));
  return NZ_OK;
fail:
  describe_failure(c, fail_plan, st);
  return st;
#undef R
#undef D
#undef CF
}
