/* lua_taylor.c - Taylor's method for Lua, on a system whose M and h (and
 * constraints, of order <= 2) are recorded (issue 11; sys:simulate{method =
 * "taylor"} runs on taylor_run, lua/nz/simulate.lua):
 *   core.mech.motion_series(engine, t0, q0, qd0, p) -> { a_0, ..., a_p }
 *     the Taylor coefficients of q(t0 + tau), each a list of k numbers;
 *   core.mech.taylor_run(engine, { t0, t1, dt, q0, qd0, tol | rtol, atol,
 *     order, max_steps, partial }) -> { t = {...}, q = {{...}}, qd = {{...}},
 *     stats = { steps, order, nfev, hmin, hmax, t, seconds } [, stop, message] }
 *     on the grid t0 + i dt (the last point at t1; dt defaults to t1 - t0),
 *     nfev counting the series of the motion computed (one per step),
 *     seconds the wall time of the run in C (the result's tables apart).
 * engine is a system's definition table (sys.engine).  A system with
 * constraints (of orders 0, 1, 2) needs their classification: the 6th
 * argument of motion_series, fields orders and linear of taylor_run's
 * opts, as sys:simulate passes them. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "mech/mech_graph.h"
#include "ode/ode_run.h"     /* nz_run_clock, nz_event_crosses */
#include "ode/taylor.h"
#include "graph/graph.h"
#include "lua/lua_graph.h"
#include "lua/lua_system.h"
#include "lua/lua_taylor.h"
#include "lua/lua_util.h"

/* Bind the system at 1 and check that Taylor's method applies to it. */
static void bind_recorded(lua_State *L, bound_system *b, const char *fname)
{
  nz_lua_bind_system(L, 1, b);
  const char *name = nz_lua_system_name(L, 1);
  if (!b->comp)
    luaL_error(L, "system '%s': '%s': the Taylor method needs a recorded system (made with compile = true, "
               "the default), whose series it builds on the graphs", name, fname);
  if (!b->sys.mass_bias)
    luaL_error(L, "system '%s': '%s': the Taylor method needs T, V and Q recorded, and one of them fell back "
               "to Lua (print(sys) says which and why)", name, fname);
}

/* The series function of a run: the free motion, or the motion under the
 * constraints (their classification in orders and linear): the start's
 * accelerations and multipliers by the constrained solver (Newton where a
 * constraint is not linear in q''), then the series order by order on the
 * saddle-point system (nz_compiled_constrained_series). */
typedef struct series_ctx {
  bound_system *b;
  int *orders, *linear;   /* nc each (NULL: free)                    */
  double *qdd, *lam;      /* the start's, k and nc                    */
  nz_accel_report rep;    /* of the last solve; failed: it failed     */
  int accel_failed;
  double t;               /* where                                    */
  double *q, *qd;         /* the state there (k each)                 */
} series_ctx;

static int motion_series(void *ctx, double t0, const double *q0, const double *qd0, int p, double *a)
{
  series_ctx *s = ctx;
  if (!s->orders) return nz_compiled_motion_series(s->b->comp, t0, q0, qd0, p, a);
  int k = s->b->sys.k;
  nz_accel_options opt = NZ_ACCEL_DEFAULTS;
  memset(&s->rep, 0, sizeof s->rep);
  int st = nz_accel_constrained(&s->b->sys, s->orders, s->linear, t0, q0, qd0, &opt, s->qdd, s->lam, &s->rep);
  if (st) {
    s->accel_failed = 1;
    s->t = t0;
    memcpy(s->q, q0, (size_t)k * sizeof(double));
    memcpy(s->qd, qd0, (size_t)k * sizeof(double));
    return st;
  }
  if (p < 2) {
    memcpy(a, q0, (size_t)k * sizeof(double));
    if (p >= 1) memcpy(a + k, qd0, (size_t)k * sizeof(double));
    return NZ_OK;
  }
  return nz_compiled_constrained_series(s->b->comp, s->orders, t0, q0, qd0, s->qdd, s->lam, p, a, NULL);
}

/* The context for b: with constraints, their classification from the
 * table at index idx (fields orders and linear, as sys:simulate passes them
 * to its integrators), in userdata on the stack. */
static void series_setup(lua_State *L, bound_system *b, int idx, series_ctx *s, const char *fname)
{
  memset(s, 0, sizeof *s);
  s->b = b;
  int nc = b->sys.nc, k = b->sys.k;
  if (nc == 0) return;
  if (!idx || lua_getfield(L, idx, "orders") != LUA_TTABLE)
    luaL_error(L, "system '%s': '%s': a system with constraints needs their classification (orders, linear; "
               "sys:simulate{method = \"taylor\"} passes it)", nz_lua_system_name(L, 1), fname);
  lua_getfield(L, idx, "linear");
  int *ints = lua_newuserdatauv(L, 2 * (size_t)(nc + 1) * sizeof(int), 0);
  double *d = lua_newuserdatauv(L, (3 * (size_t)k + (size_t)nc + 1) * sizeof(double), 0);
  s->orders = ints;
  s->linear = ints + nc + 1;
  s->qdd = d, s->q = d + k, s->qd = d + 2 * k, s->lam = d + 3 * k;
  int top = lua_gettop(L);
  for (int r = 0; r < nc; r++) {
    lua_geti(L, top - 3, r + 1);
    s->orders[r] = (int)luaL_checkinteger(L, -1);
    lua_geti(L, top - 2, r + 1);
    s->linear[r] = lua_toboolean(L, -1);
    lua_pop(L, 2);
    if (s->orders[r] < 0 || s->orders[r] > 2)
      luaL_error(L, "system '%s': '%s': constraint %d is of order %d; the Taylor method takes constraints of order "
                 "0, 1 and 2", nz_lua_system_name(L, 1), fname, r + 1, s->orders[r]);
  }
  s->rep.A = NULL;
}

/* A failed constrained solve at a step's start, raised with where. */
static int raise_accel(lua_State *L, series_ctx *s)
{
  return nz_lua_raise_accel_failure(L, 1, &s->rep, s->orders, s->t, s->q, s->qd, s->b->sys.k, s->b->sys.nc);
}

/* The error of a failed series, with where it failed. */
static int raise_series(lua_State *L, bound_system *b, int st, double t, const char *fname)
{
  const char *name = nz_lua_system_name(L, 1);
  char num[64];
  nz_lua_fmt_num(num, sizeof num, t);
  if (st == NZ_ENOMEM) return luaL_error(L, "system '%s': not enough memory in '%s'", name, fname);
  if (st == NZ_EARG)
    return luaL_error(L, "system '%s': '%s': the mass matrix and bias are not recorded", name, fname);
  return luaL_error(L, "system '%s': '%s': the series of the motion failed at t = %s: %s (status %d)", name,
                    fname, num, nz_compiled_failure(b->comp), st);
}

/* motion_series(engine, t0, q0, qd0, p [, {orders, linear}]) -> { a_0, ..., a_p } */
static int lt_motion_series(lua_State *L)
{
  lua_settop(L, 6);
  bound_system b;
  bind_recorded(L, &b, "motion_series");
  series_ctx sc;
  series_setup(L, &b, lua_istable(L, 6) ? 6 : 0, &sc, "motion_series");
  int k = b.sys.k;
  double t0 = luaL_checknumber(L, 2);
  lua_Integer p = luaL_checkinteger(L, 5);
  luaL_argcheck(L, p >= 0 && p <= 1000, 5, "order out of range (0 .. 1000)");
  double *buf = lua_newuserdatauv(L, ((size_t)p + 3) * (size_t)k * sizeof(double), 0);
  double *q0 = buf, *qd0 = buf + k, *a = buf + 2 * k;
  nz_lua_read_vector(L, 3, k, q0, "q0", 0, "motion_series");
  nz_lua_read_vector(L, 4, k, qd0, "qd0", 1, "motion_series");
  int st = motion_series(&sc, t0, q0, qd0, (int)p, a);
  if (st && sc.accel_failed) return raise_accel(L, &sc);
  if (st) return raise_series(L, &b, st, t0, "motion_series");
  lua_createtable(L, (int)p + 1, 0);
  for (int n = 0; n <= p; n++) {
    nz_lua_push_vector(L, a + (size_t)n * (size_t)k, k);
    lua_rawseti(L, -2, n + 1);
  }
  return 1;
}

/* Events on the series (sys:simulate's events, recorded as graphs: opts.
 * events = { compiled, nodes = {node per event}, values = {parameters},
 * directions = {...}, stops = {...}, tol = event_tol }).  After each step
 * the hook evaluates every g at the step's end on its polynomial; a sign
 * change (as simulate.lua's crosses()) is located by Illinois' regula falsi
 * on g(q(tau), q'(tau)), tau in [0, h], without integrating again, and
 * recorded (time, event, q, q'); one that stops the run cuts the step there.
 * At most NZ_TAYLOR_MAX_EVENTS per call of taylor_run (a chunk of
 * simulate's grid): more fails the run, NZ_ERANGE. */
#define NZ_TAYLOR_MAX_EVENTS 4096
typedef struct taylor_events {
  int n, k, np, count, failed_e;
  nz_graph_plan **plans;
  const int *dir;
  const int *stops;
  double *in, *gprev, *y, tol;
  double *te, *qe;             /* count times; count x 2k states             */
  int *ee;                     /* count event numbers (0-based)              */
} taylor_events;

static int ev_value(taylor_events *ev, int e, double t, int k, int P, const double *a, double tau, double *g)
{
  nz_taylor_eval(k, P, a, tau, ev->y, ev->y + k);
  ev->in[0] = t + tau;
  memcpy(ev->in + 1 + ev->np, ev->y, 2 * (size_t)k * sizeof(double));
  int st = nz_graph_eval(ev->plans[e], ev->in, g);
  if (!st && !isfinite(*g)) st = NZ_EDOM;
  if (st) ev->failed_e = e;
  return st;
}


static int events_step(void *ctx, double t, double h, int k, int P, const double *a, double *cut)
{
  taylor_events *ev = ctx;
  int first = ev->count;
  for (int e = 0; e < ev->n; e++) {
    double gb, ga = ev->gprev[e];
    int st = ev_value(ev, e, t, k, P, a, h, &gb);
    if (st) return st;
    ev->gprev[e] = gb;
    if (!nz_event_crosses(ev->dir[e], ga, gb)) continue;
    /* Illinois on [0, h], as locate() in simulate.lua */
    double ta = 0.0, tb = h, tol = ev->tol * fmax(1.0, fabs(t + h)), gm;
    int side = 0;
    if (gb != 0.0) {
      for (int it = 0; it < 100 && tb - ta > tol; it++) {
        double tm = (ta * gb - tb * ga) / (gb - ga);
        if (!(tm > ta && tm < tb)) tm = 0.5 * (ta + tb);
        if ((st = ev_value(ev, e, t, k, P, a, tm, &gm))) return st;
        if (gm == 0.0) { ta = tb = tm; break; }
        if ((gm > 0.0) == (ga > 0.0)) {
          ta = tm, ga = gm;
          if (side == -1) gb /= 2;
          side = -1;
        } else {
          tb = tm, gb = gm;
          if (side == 1) ga /= 2;
          side = 1;
        }
      }
    }
    if (ev->count >= NZ_TAYLOR_MAX_EVENTS) return NZ_ERANGE;
    int c = ev->count++;
    ev->te[c] = tb;                /* tau for now: made a time below */
    ev->ee[c] = e;
    nz_taylor_eval(k, P, a, tb, ev->qe + (size_t)c * 2 * (size_t)k, ev->qe + (size_t)c * 2 * (size_t)k + k);
  }
  /* the events of this step in time order; the earliest that stops cuts
   * the step, and the later ones are not reached */
  for (int i = first + 1; i < ev->count; i++)
    for (int j = i; j > first && ev->te[j] < ev->te[j - 1]; j--) {
      double tt = ev->te[j]; ev->te[j] = ev->te[j - 1]; ev->te[j - 1] = tt;
      int ie = ev->ee[j]; ev->ee[j] = ev->ee[j - 1]; ev->ee[j - 1] = ie;
      for (int i2 = 0; i2 < 2 * k; i2++) {
        double *x = ev->qe + (size_t)j * 2 * (size_t)k + i2, *w = x - 2 * (size_t)k, v = *x;
        *x = *w, *w = v;
      }
    }
  for (int i = first; i < ev->count; i++) {
    double tau = ev->te[i];
    ev->te[i] = t + tau;
    if (ev->stops[ev->ee[i]]) {
      *cut = tau;
      ev->count = i + 1;
      break;
    }
  }
  return NZ_OK;
}

/* opts.name as a number, or def when absent. */
static double opt_number(lua_State *L, int idx, const char *name, double def)
{
  int type = lua_getfield(L, idx, name);
  double v = def;
  if (type != LUA_TNIL) {
    int isnum;
    v = lua_tonumberx(L, -1, &isnum);
    if (!isnum) luaL_error(L, "bad argument to 'taylor_run' (%s must be a number, got %s)", name, luaL_typename(L, -1));
  }
  lua_pop(L, 1);
  return v;
}

/* The statistics of a run as a table on the stack. */
static void push_stats(lua_State *L, const nz_taylor_stats *stats, double seconds)
{
  lua_createtable(L, 0, 7);
  lua_pushinteger(L, (lua_Integer)stats->steps);
  lua_setfield(L, -2, "steps");
  lua_pushinteger(L, stats->order);
  lua_setfield(L, -2, "order");
  lua_pushinteger(L, (lua_Integer)stats->nseries);
  lua_setfield(L, -2, "nfev");
  lua_pushnumber(L, stats->hmin);
  lua_setfield(L, -2, "hmin");
  lua_pushnumber(L, stats->hmax);
  lua_setfield(L, -2, "hmax");
  lua_pushnumber(L, stats->t);
  lua_setfield(L, -2, "t");
  lua_pushnumber(L, seconds);            /* the run in C, without the Lua tables of the result */
  lua_setfield(L, -2, "seconds");
}

/* opts.tr (sys:simulate's trajectory, at stack index tr): the run's points
 * but its first (the last one of the chunk before) appended to tr.t, tr.q,
 * tr.qd, tr.qdd, tr.lambda as simulate.lua's record() stores them, the time
 * of point m being t0 + (i0 + m) dt of the whole grid (opts.grid_t0, i0,
 * nout, grid_t1; t1 for the last), so that the chunks' own grids, which
 * start at the chunk's start, leave no trace of their rounding in tr.t.
 * qdd is the system's accelerations at the point's (q, q'): 2 a_2 of the
 * series at order 2 there (the step's polynomial's second derivative would
 * carry its truncation, ~p^2 / h^2 times the tolerance).  No Lua function
 * runs here: Ctrl-C's hook cannot cut a point in half.  Returns { n =
 * points appended, q, qd = the last point's, stats, stop, message }. */
static int append_points(lua_State *L, series_ctx *sc, int tr, const double *tout, const double *qout,
                         const double *qdout, long n, const nz_taylor_stats *stats, double seconds,
                         const char *why, const char *what, const taylor_events *ev)
{
  bound_system *b = sc->b;
  (void)tout;
  int k = b->sys.k;
  double gt0 = opt_number(L, 2, "grid_t0", NAN), gdt = opt_number(L, 2, "dt", NAN);
  double gt1 = opt_number(L, 2, "grid_t1", NAN);
  double i0 = opt_number(L, 2, "i0", 0.0), nout = opt_number(L, 2, "nout", 0.0);
  static const char *const series[] = { "t", "q", "qd", "qdd", "lambda" };
  int base = lua_gettop(L);
  for (int j = 0; j < 5; j++) {      /* at base + 1 .. base + 5 */
    lua_pushstring(L, series[j]);
    if (lua_rawget(L, tr) != LUA_TTABLE) luaL_error(L, "simulate: tr.%s is not a table", series[j]);
  }
  double *acc = lua_newuserdatauv(L, 3 * (size_t)k * sizeof(double), 0);
  lua_Integer first = (lua_Integer)lua_rawlen(L, base + 1) + 1;
  for (long m = 1; m < n; m++) {
    const double *q = qout + (size_t)m * (size_t)k, *qd = qdout + (size_t)m * (size_t)k;
    double idx = i0 + (double)m, t = idx == nout ? gt1 : gt0 + idx * gdt;
    /* q'' (and the multipliers) at the point, as the GSL runs record them */
    if (sc->orders) {
      nz_accel_options opt = NZ_ACCEL_DEFAULTS;
      memset(&sc->rep, 0, sizeof sc->rep);
      if (nz_accel_constrained(&b->sys, sc->orders, sc->linear, t, q, qd, &opt, acc, sc->lam, &sc->rep)) {
        sc->t = t;
        memcpy(sc->q, q, (size_t)k * sizeof(double));
        memcpy(sc->qd, qd, (size_t)k * sizeof(double));
        return raise_accel(L, sc);
      }
    } else {
      int st = nz_compiled_motion_series(b->comp, t, q, qd, 2, acc);
      if (st) return raise_series(L, b, st, t, "simulate");
      for (int i = 0; i < k; i++) acc[i] = 2.0 * acc[2 * k + i];
    }
    lua_Integer at = first + m - 1;
    lua_pushnumber(L, t);
    lua_rawseti(L, base + 1, at);
    nz_lua_push_vector(L, q, k);
    lua_rawseti(L, base + 2, at);
    nz_lua_push_vector(L, qd, k);
    lua_rawseti(L, base + 3, at);
    nz_lua_push_vector(L, acc, k);
    lua_rawseti(L, base + 4, at);
    if (sc->orders) nz_lua_push_vector(L, sc->lam, b->sys.nc);
    else lua_createtable(L, 0, 0);
    lua_rawseti(L, base + 5, at);
  }
  lua_createtable(L, 0, 6);
  lua_pushinteger(L, n > 0 ? (lua_Integer)n - 1 : 0);
  lua_setfield(L, -2, "n");
  if (n > 0) {
    nz_lua_push_vector(L, qout + (size_t)(n - 1) * (size_t)k, k);
    lua_setfield(L, -2, "q");
    nz_lua_push_vector(L, qdout + (size_t)(n - 1) * (size_t)k, k);
    lua_setfield(L, -2, "qd");
  }
  if (why) {
    lua_pushstring(L, why);
    lua_setfield(L, -2, "stop");
    lua_pushstring(L, what);
    lua_setfield(L, -2, "message");
  }
  lua_createtable(L, ev->count, 0);     /* { {e (1-based), t, q, qd}, ... } in time order */
  for (int c = 0; c < ev->count; c++) {
    lua_createtable(L, 0, 4);
    lua_pushinteger(L, ev->ee[c] + 1);
    lua_setfield(L, -2, "e");
    lua_pushnumber(L, ev->te[c]);
    lua_setfield(L, -2, "t");
    nz_lua_push_vector(L, ev->qe + (size_t)c * 2 * (size_t)k, k);
    lua_setfield(L, -2, "q");
    nz_lua_push_vector(L, ev->qe + (size_t)c * 2 * (size_t)k + k, k);
    lua_setfield(L, -2, "qd");
    lua_rawseti(L, -2, c + 1);
  }
  lua_setfield(L, -2, "events");
  push_stats(L, stats, seconds);
  lua_setfield(L, -2, "stats");
  return 1;
}

/* taylor_run(engine, opts) -> { t, q, qd, stats } */
static int lt_taylor_run(lua_State *L)
{
  lua_settop(L, 2);
  bound_system b;
  bind_recorded(L, &b, "taylor_run");
  luaL_checktype(L, 2, LUA_TTABLE);
  /* The polynomial of a step is the continuation of the branch taken at its
   * start: across a switch (abs(x) at x = 0) it is silently wrong, and its
   * coefficients do not show it (a V-shaped well gives a parabola, exact to
   * every order, and one step to t1). */
  int branches = nz_compiled_motion_branches(b.comp);
  if (branches > 0)
    return luaL_error(L, "system '%s': 'taylor_run': the Taylor method does not step across branches yet, and "
                      "M or h has %d (comparisons, nz.ifelse, min, max, abs or sign on the state)",
                      nz_lua_system_name(L, 1), branches);
  int k = b.sys.k;
  series_ctx sc;
  series_setup(L, &b, 2, &sc, "taylor_run");
  nz_taylor_config cfg;
  memset(&cfg, 0, sizeof cfg);
  cfg.t0 = opt_number(L, 2, "t0", 0.0);
  cfg.t1 = opt_number(L, 2, "t1", NAN);
  cfg.dt = opt_number(L, 2, "dt", cfg.t1 - cfg.t0);
  double tol = opt_number(L, 2, "tol", 1e-12);
  cfg.rtol = opt_number(L, 2, "rtol", tol);
  cfg.atol = opt_number(L, 2, "atol", tol);
  double order = opt_number(L, 2, "order", 0.0), max_steps = opt_number(L, 2, "max_steps", 0.0);
  if (!isfinite(cfg.t0) || !isfinite(cfg.t1) || !(cfg.t1 > cfg.t0))
    return luaL_error(L, "bad argument to 'taylor_run' (t1 must be a finite number after t0)");
  if (!(cfg.dt > 0.0) || !isfinite(cfg.dt))
    return luaL_error(L, "bad argument to 'taylor_run' (dt must be a positive finite number)");
  if (!(cfg.rtol >= 0.0 && cfg.rtol < 1.0 && cfg.atol >= 0.0 && cfg.atol < 1.0) || (cfg.rtol == 0.0 && cfg.atol == 0.0))
    return luaL_error(L, "bad argument to 'taylor_run' (tolerances must lie in [0, 1), not both 0)");
  if (!(order == 0.0 || (order >= 2.0 && order <= 1000.0 && order == floor(order))))
    return luaL_error(L, "bad argument to 'taylor_run' (order must be a whole number in 2 .. 1000)");
  if (!(max_steps >= 0.0 && max_steps == floor(max_steps)))
    return luaL_error(L, "bad argument to 'taylor_run' (max_steps must be a whole number >= 0)");
  cfg.order = (int)order;
  cfg.max_steps = (unsigned long)max_steps;
  long npts = nz_taylor_grid_count(&cfg);
  if (npts < 2) return luaL_error(L, "bad argument to 'taylor_run' (the output grid t0 .. t1 by dt is too long)");
  double *q0 = lua_newuserdatauv(L, 2 * (size_t)k * sizeof(double), 0), *qd0 = q0 + k;
  lua_getfield(L, 2, "q0");
  nz_lua_read_vector(L, lua_gettop(L), k, q0, "q0", 0, "taylor_run");
  lua_getfield(L, 2, "qd0");
  nz_lua_read_vector(L, lua_gettop(L), k, qd0, "qd0", 1, "taylor_run");
  lua_pop(L, 2);
  double *out = lua_newuserdatauv(L, (size_t)npts * (1 + 2 * (size_t)k) * sizeof(double), 0);
  double *tout = out, *qout = out + npts, *qdout = qout + (size_t)npts * (size_t)k;
  long n = 0;
  nz_taylor_stats stats;
  nz_taylor_stop stop;
  /* events (see taylor_events): workspace in userdata, plans freed below */
  taylor_events ev;
  memset(&ev, 0, sizeof ev);
  lua_getfield(L, 2, "events");
  int evidx = lua_istable(L, -1) ? lua_gettop(L) : 0;
  if (evidx) {
    lua_getfield(L, evidx, "compiled");
    nz_compiled *c = nz_lua_tocompiled(L, -1);
    if (!c) return luaL_error(L, "bad argument to 'taylor_run' (events.compiled must be a recording)");
    nz_graph *g = nz_compiled_graph(c);
    lua_pop(L, 1);
    lua_getfield(L, evidx, "nodes");
    lua_getfield(L, evidx, "values");
    lua_getfield(L, evidx, "directions");
    lua_getfield(L, evidx, "stops");
    int ni = evidx + 1;
    ev.n = (int)luaL_len(L, ni);
    ev.np = (int)luaL_len(L, ni + 1);
    ev.k = k;
    ev.tol = opt_number(L, evidx, "tol", 1e-12);
    size_t nin = (size_t)(1 + ev.np + 2 * k) + (size_t)nz_graph_ninputs(g);
    size_t nd = nin + (size_t)ev.n + 2 * (size_t)k + NZ_TAYLOR_MAX_EVENTS * (1 + 2 * (size_t)k);
    /* plans (pointers), then doubles, then ints: each part aligned */
    char *base = lua_newuserdatauv(L, (size_t)ev.n * sizeof(nz_graph_plan *) + nd * sizeof(double)
                                   + (size_t)(2 * ev.n + NZ_TAYLOR_MAX_EVENTS) * sizeof(int), 0);
    ev.plans = (nz_graph_plan **)(void *)base;
    double *w = (double *)(void *)(base + (size_t)ev.n * sizeof(nz_graph_plan *));
    memset(w, 0, nd * sizeof(double));
    ev.in = w, ev.gprev = w + nin, ev.y = ev.gprev + ev.n, ev.te = ev.y + 2 * k, ev.qe = ev.te + NZ_TAYLOR_MAX_EVENTS;
    int *iw = (int *)(void *)(w + nd);
    int *dir = iw, *stops = iw + ev.n;
    ev.ee = iw + 2 * ev.n;
    ev.dir = dir, ev.stops = stops;
    for (int p = 0; p < ev.np; p++) {
      lua_geti(L, ni + 1, p + 1);
      ev.in[1 + p] = luaL_checknumber(L, -1);
      lua_pop(L, 1);
    }
    for (int e = 0; e < ev.n; e++) {
      lua_geti(L, ni + 2, e + 1);
      dir[e] = (int)luaL_optinteger(L, -1, 0);
      lua_geti(L, ni + 3, e + 1);
      stops[e] = lua_toboolean(L, -1);
      lua_geti(L, ni, e + 1);
      lua_Integer id = luaL_checkinteger(L, -1);
      lua_pop(L, 3);
      ev.plans[e] = NULL;
      if (id < 0 || id >= nz_graph_size(g)) return luaL_error(L, "internal: event %d: node %d is not in the graph", e + 1, (int)id);
    }
    int bad = 0;
    for (int e = 0; e < ev.n; e++) {
      lua_geti(L, ni, e + 1);
      int node = (int)lua_tointeger(L, -1);
      lua_pop(L, 1);
      if (!(ev.plans[e] = nz_graph_plan_new(g, &node, 1))) bad = 1;
    }
    /* g at the start (the chunk's first point) */
    for (int e = 0; !bad && e < ev.n; e++) {
      ev.in[0] = cfg.t0;
      memcpy(ev.in + 1 + ev.np, q0, (size_t)k * sizeof(double));
      memcpy(ev.in + 1 + ev.np + k, qd0, (size_t)k * sizeof(double));
      if (nz_graph_eval(ev.plans[e], ev.in, &ev.gprev[e])) bad = 2;
    }
    if (bad) {
      for (int e = 0; e < ev.n; e++) nz_graph_plan_free(ev.plans[e]);
      return luaL_error(L, bad == 1 ? "not enough memory for the events" :
                        "system '%s': an event's recorded function fails at the start of a chunk", nz_lua_system_name(L, 1));
    }
    cfg.on_step = events_step;
    cfg.step_ctx = &ev;
  }
  lua_getfield(L, 2, "partial");
  int partial = lua_toboolean(L, -1);
  lua_pop(L, 1);
  char what[512] = "";
  const char *why = NULL;
  double clock0 = nz_run_clock();
  int st = nz_taylor_run(k, motion_series, &sc, &cfg, q0, qd0, tout, qout, qdout, &n, &stats, &stop);
  double seconds = nz_run_clock() - clock0;
  for (int e = 0; e < ev.n; e++) nz_graph_plan_free(ev.plans[e]);
  if (stop == NZ_TAYLOR_HOOK) {
    char num[64];
    nz_lua_fmt_num(num, sizeof num, stats.t);
    if (!partial) return luaL_error(L, "'taylor_run': events failed at t = %s (status %d)", num, st);
    snprintf(what, sizeof what, st == NZ_ERANGE ? "stopped at t = %s: more than %d events in one chunk of the output grid"
             : "stopped in the step from t = %s: event %d's recorded function failed (a domain error, or not "
             "finite) on the step's polynomial", num,
             st == NZ_ERANGE ? NZ_TAYLOR_MAX_EVENTS : ev.failed_e + 1);
    why = "hook";
  }
  if (stop == NZ_TAYLOR_CUT) why = "event";
  /* partial = true (sys:simulate): a run that stops early returns the points
   * it wrote, with stop = why and message = what, so that the caller keeps
   * them; otherwise it raises. */
  if (stop == NZ_TAYLOR_INTERRUPTED) {
    if (!partial) return nz_lua_raise_interrupt(L);
    why = "interrupted";
  } else if (stop == NZ_TAYLOR_SERIES) {
    if (!partial && sc.accel_failed) return raise_accel(L, &sc);
    if (!partial) return raise_series(L, &b, st, stats.t, "taylor_run");
    char num[64];
    nz_lua_fmt_num(num, sizeof num, stats.t);
    why = "series";
    if (st == NZ_ENOMEM) snprintf(what, sizeof what, "not enough memory");
    else if (sc.accel_failed)
      snprintf(what, sizeof what, "the accelerations under the constraints could not be solved at t = %s (%s)", num,
               sc.rep.failure == NZ_ACCEL_SINGULAR ? "the matrix [M A^T; A 0] is singular there"
               : sc.rep.failure == NZ_ACCEL_NEWTON ? "Newton's method did not converge"
               : "the solution failed its check");
    else snprintf(what, sizeof what, "the series of the motion failed at t = %s: %s (status %d)", num,
                  nz_compiled_failure(b.comp), st);
  } else if (stop == NZ_TAYLOR_STEP || stop == NZ_TAYLOR_MAX_STEPS) {
    char num[64];
    nz_lua_fmt_num(num, sizeof num, stats.t);
    if (!partial)
      return luaL_error(L, "system '%s': 'taylor_run' stopped at t = %s: %s", nz_lua_system_name(L, 1), num,
                        stop == NZ_TAYLOR_STEP ? "the step size became too small" : "max_steps reached");
    why = stop == NZ_TAYLOR_STEP ? "step" : "max_steps";
    snprintf(what, sizeof what, "stopped at t = %s: %s", num,
             stop == NZ_TAYLOR_STEP ? "the step size became too small" : "max_steps reached");
  } else if (stop == NZ_TAYLOR_HOOK) {
    /* said above (what, why) */
  } else if (st == NZ_ENOMEM) {
    return luaL_error(L, "system '%s': not enough memory in 'taylor_run'", nz_lua_system_name(L, 1));
  } else if (st) {
    return luaL_error(L, "system '%s': 'taylor_run' failed (status %d)", nz_lua_system_name(L, 1), st);
  }
  lua_getfield(L, 2, "tr");
  int tr = lua_istable(L, -1) ? lua_gettop(L) : 0;
  if (tr) return append_points(L, &sc, tr, tout, qout, qdout, n, &stats, seconds, why, what, &ev);
  lua_pop(L, 1);
  lua_createtable(L, 0, 6);
  if (why) {
    lua_pushstring(L, why);
    lua_setfield(L, -2, "stop");
    lua_pushstring(L, what);
    lua_setfield(L, -2, "message");
  }
  lua_createtable(L, (int)n, 0);
  for (long i = 0; i < n; i++) {
    lua_pushnumber(L, tout[i]);
    lua_rawseti(L, -2, i + 1);
  }
  lua_setfield(L, -2, "t");
  for (int w = 0; w < 2; w++) {
    const double *v = w ? qdout : qout;
    lua_createtable(L, (int)n, 0);
    for (long i = 0; i < n; i++) {
      nz_lua_push_vector(L, v + (size_t)i * (size_t)k, k);
      lua_rawseti(L, -2, i + 1);
    }
    lua_setfield(L, -2, w ? "qd" : "q");
  }
  push_stats(L, &stats, seconds);
  lua_setfield(L, -2, "stats");
  return 1;
}

/* taylor_order(eps) -> the order a run takes at tolerance eps (taylor.h) */
static int lt_order(lua_State *L)
{
  lua_pushinteger(L, nz_taylor_order(luaL_checknumber(L, 1)));
  return 1;
}

static const luaL_Reg taylor_functions[] = {
  { "motion_series", lt_motion_series }, { "taylor_run", lt_taylor_run }, { "taylor_order", lt_order },
  { NULL, NULL }
};

void nz_lua_open_taylor(lua_State *L) { luaL_setfuncs(L, taylor_functions, 0); }
