/* lua_taylor.c - Taylor's method for Lua, on a system whose M and h (and
 * constraints, of order <= 2) are recorded.  The integrator
 * (ode/taylor_motion.h) is made here for core.mech.ode_new{method = "taylor"}
 * (lua_ode.c), so that sys:simulate runs it through the same stepping loop
 * as GSL's steppers (ode/ode_run.h); and two functions go to core.mech:
 *   core.mech.motion_series(engine, t0, q0, qd0, p) -> { a_0, ..., a_p }
 *     the Taylor coefficients of q(t0 + tau), each a list of k numbers;
 *   core.mech.taylor_run(engine, { t0, t1, dt, q0, qd0, tol | rtol, atol,
 *     order, max_steps }) -> { t = {...}, q = {{...}}, qd = {{...}},
 *     stats = { steps, order, nfev, hmin, hmax, t, seconds } }
 *     the same loop with dense output on the grid t0 + i dt (the last point
 *     at t1; dt defaults to t1 - t0) and nothing recorded but t, q, qd (for
 *     tests and bench/taylor.lua), nfev counting the series of the motion
 *     computed (one per step), seconds the wall time of the run in C.
 * engine is a system's definition table (sys.engine).  A system with
 * constraints (of orders 0, 1, 2) needs their classification: the 6th
 * argument of motion_series, fields orders and linear of taylor_run's
 * opts and of ode_new's configuration, as sys:simulate passes them. */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "mech/contact.h"
#include "mech/mech_graph.h"
#include "ode/ode_run.h"
#include "ode/taylor_motion.h"
#include "lua/lua_contact.h"
#include "lua/lua_system.h"
#include "lua/lua_taylor.h"
#include "lua/lua_util.h"

/* Bind the system at 1 and check that Taylor's method applies to it. */
static void bind_recorded(lua_State *L, bound_system *b, const char *fname)
{
  nz_lua_bind_system(L, 1, b);
  const char *name = nz_lua_system_name(L, 1);
  if (!b->comp)
    nz_lua_error(L, "system '%s': '%s': the Taylor method needs a recorded system (made with compile = true, "
               "the default), whose series it builds on the graphs", name, fname);
  if (!b->sys.mass_bias)
    nz_lua_error(L, "system '%s': '%s': the Taylor method needs T, V and Q recorded, and one of them fell back "
               "to Lua (print(sys) says which and why)", name, fname);
  for (int r = 0; r < b->sys.nc; r++)   /* else the first series would fail with a status, not this reason */
    if (!nz_recording_has(b->comp, NZ_PIECE_PHI, r))
      luaL_error(L, "system '%s': '%s': the Taylor method needs the constraints recorded, and constraint %d "
                 "runs in Lua (print(sys) says why)", name, fname, r + 1);
}

/* The constraints' classification from the table at index idx (fields
 * orders and linear, as sys:simulate passes them to its integrators) into
 * the setup; the arrays are left on the stack (the stepper copies them). */
static void read_setup(lua_State *L, bound_system *b, int idx, const char *fname, nz_motion_setup *m)
{
  int nc = b->sys.nc, k = b->sys.k;
  int *flags = lua_newuserdatauv(L, 2 * ((size_t)nc + 1) * sizeof(int), 0);
  if (nc > 0) {
    if (!idx || lua_getfield(L, idx, "orders") != LUA_TTABLE)
      nz_lua_error(L, "system '%s': '%s': a system with constraints needs their classification (orders, linear; "
                 "sys:simulate{method = \"taylor\"} passes it)", nz_lua_system_name(L, 1), fname);
    lua_pop(L, 1);
    nz_lua_field_ints(L, idx, "orders", nc, flags);
    nz_lua_field_ints(L, idx, "linear", nc, flags + nc + 1);
    for (int r = 0; r < nc; r++)
      if (flags[r] > 2)
        nz_lua_error(L, "system '%s': '%s': constraint %d is of order %d; the Taylor method takes constraints of order "
                   "0, 1 and 2", nz_lua_system_name(L, 1), fname, r + 1, flags[r]);
  }
  nz_accel_options opt = NZ_ACCEL_DEFAULTS;
  *m = (nz_motion_setup){ k, nc, nc > 0 ? flags : NULL, nc > 0 ? flags + nc + 1 : NULL, NULL, opt };
  if (idx) {                         /* unilateral contacts: their mode's series (kept alive by ode_new's box) */
    lua_getfield(L, idx, "contacts");
    m->contacts = nz_lua_tocontacts(L, -1);
    lua_pop(L, 1);
  }
}

/* A failed solve of the motion (a singular M, the constraints), raised
 * with where: NULL-safe, 0 when the stepper's last failure was not one. */
static int raise_motion(lua_State *L, nz_stepper *st)
{
  double t;
  const double *q, *qd;
  const nz_motion_outcome *oc = nz_taylor_motion_failure(st, &t, &q, &qd);
  const nz_motion_setup *m = nz_taylor_motion_setup(st);
  if (!oc) return 0;
  if (oc->failed == NZ_MOTION_FAILED_MASS) return nz_lua_raise_singular_mass(L, 1, t, q, qd, m->k, &oc->mass);
  if (oc->failed == NZ_MOTION_FAILED_CONSTRAINTS)
    return nz_lua_raise_accel_failure(L, 1, &oc->rep, m->orders, t, q, qd, m->k, m->nc);
  return 0;
}

/* The error of a failed series, with where it failed. */
static int raise_series(lua_State *L, bound_system *b, int st, double t, const char *fname)
{
  const char *name = nz_lua_system_name(L, 1);
  char num[64];
  nz_lua_fmt_num(num, sizeof num, t);
  if (st == NZ_ENOMEM) return nz_lua_error(L, "system '%s': not enough memory in '%s'", name, fname);
  if (st == NZ_EARG)
    return nz_lua_error(L, "system '%s': '%s': the mass matrix and bias are not recorded", name, fname);
  return nz_lua_error(L, "system '%s': '%s': the series of the motion failed at t = %s: %s (status %d)", name,
                    fname, num, nz_recording_failure(b->comp), st);
}

/* opts.name as a number, or def when absent. */
static double opt_number(lua_State *L, int idx, const char *name, double def, const char *fname)
{
  int type = lua_getfield(L, idx, name);
  double v = def;
  if (type != LUA_TNIL) {
    int isnum;
    v = lua_tonumberx(L, -1, &isnum);
    if (!isnum) nz_lua_error(L, "bad argument to '%s' (%s must be a number, got %s)", fname, name, luaL_typename(L, -1));
  }
  lua_pop(L, 1);
  return v;
}


nz_stepper *nz_lua_taylor_new(lua_State *L, int cfg, const char *fname)
{
  bound_system b;
  bind_recorded(L, &b, fname);
  /* The polynomial of a step is the continuation of the branch taken at its
   * start: across a switch (abs(x) at x = 0) it is silently wrong, and its
   * coefficients do not show it (a V-shaped well gives a parabola, exact to
   * every order, and one step to t1). */
  int branches = nz_recording_motion_branches(b.comp);
  if (branches > 0)
    nz_lua_error(L, "system '%s': '%s': the Taylor method does not step across branches yet, and "
               "M or h has %d (comparisons, nz.ifelse, min, max, abs or sign on the state)",
               nz_lua_system_name(L, 1), fname, branches);
  nz_taylor_motion_config tc;
  memset(&tc, 0, sizeof tc);
  double tol = opt_number(L, cfg, "tol", 1e-12, fname);
  tc.rtol = opt_number(L, cfg, "rtol", tol, fname);
  tc.atol = opt_number(L, cfg, "atol", tol, fname);
  double order = opt_number(L, cfg, "order", 0.0, fname);
  if (!(tc.rtol >= 0.0 && tc.rtol < 1.0 && tc.atol >= 0.0 && tc.atol < 1.0) || (tc.rtol == 0.0 && tc.atol == 0.0))
    nz_lua_error(L, "bad argument to '%s' (tolerances must lie in [0, 1), not both 0)", fname);
  if (!(order == 0.0 || (order >= 2.0 && order <= 1000.0 && order == floor(order))))
    nz_lua_error(L, "bad argument to '%s' (order must be a whole number in 2 .. 1000)", fname);
  tc.order = (int)order;
  read_setup(L, &b, cfg, fname, &tc.setup);
  nz_stepper *st = nz_taylor_motion_new(&tc);
  lua_pop(L, 1);                     /* (the setup's arrays: copied) */
  if (!st) luaL_error(L, "not enough memory for the integrator");
  return st;
}

/* taylor_run's integrator and run, freed by the collector whatever raises. */
#define TAYLOR_RUN_METATABLE "nz.taylor_run"
typedef struct taylor_box {
  nz_stepper *st;
  nz_run *r;
} taylor_box;

static int taylor_box_gc(lua_State *L)
{
  taylor_box *tb = luaL_checkudata(L, 1, TAYLOR_RUN_METATABLE);
  nz_run_free(tb->r);
  nz_stepper_free(tb->st);
  tb->r = NULL;
  tb->st = NULL;
  return 0;
}

/* What stopped a Taylor step: why (a word) and what (a sentence), or
 * NULL when what failed was a solve of the motion (raise_motion) or a user
 * function (its error). */
static const char *failure_text(nz_stepper *st, nz_recording *comp, char *what, size_t n, double *tfail)
{
  int status;
  double t, tm;
  const double *q, *qd;
  nz_taylor_failure f = nz_taylor_last_failure(st, &status, &t, NULL);
  char num[64];
  nz_lua_fmt_num(num, sizeof num, t);
  *tfail = t;
  if (f == NZ_TAYLOR_STEP) {
    snprintf(what, n, "stopped at t = %s: the step size became too small", num);
    return "step";
  }
  if (f != NZ_TAYLOR_SERIES) return NULL;
  if (status == NZ_ENOMEM) snprintf(what, n, "not enough memory");
  else if (nz_taylor_motion_failure(st, &tm, &q, &qd))   /* the start of the series: said as the GSL steppers say it */
    return NULL;
  else snprintf(what, n, "the series of the motion failed at t = %s: %s (status %d)", num, nz_recording_failure(comp),
                status);
  return "series";
}

int nz_lua_taylor_raise(lua_State *L, nz_stepper *st, int status)
{
  char what[512];
  double t;
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  const char *why = failure_text(st, b.comp, what, sizeof what, &t);
  if (!why && raise_motion(L, st)) return 0;
  if (!why) return nz_lua_raise_core(L, &b, status ? status : NZ_EFUNC, "simulate");   /* a user function's error */
  /* { taylor_stop = why, message = what }: simulate.lua says it with the
   * user's line and the last output point */
  lua_createtable(L, 0, 2);
  lua_pushstring(L, why);
  lua_setfield(L, -2, "taylor_stop");
  const double *y = NULL;
  nz_taylor_last_failure(st, NULL, NULL, &y);
  if (strcmp(why, "step") == 0 && y) {   /* the state where the steps ran out, not only the time */
    luaL_Buffer msg;
    luaL_buffinit(L, &msg);
    luaL_addstring(&msg, "stopped");
    nz_lua_add_state(&msg, t, y, y + b.sys.k, b.sys.k);
    luaL_addstring(&msg, ": the step size became too small");
    luaL_pushresult(&msg);
  } else
    lua_pushstring(L, what);
  lua_setfield(L, -2, "message");
  return lua_error(L);
}

/* A box for an integrator (and a run) that the collector frees, left on the stack. */
static taylor_box *new_box(lua_State *L)
{
  taylor_box *tb = lua_newuserdatauv(L, sizeof *tb, 0);
  memset(tb, 0, sizeof *tb);
  nz_lua_gc_metatable(L, TAYLOR_RUN_METATABLE, taylor_box_gc);
  luaL_setmetatable(L, TAYLOR_RUN_METATABLE);
  return tb;
}

/* motion_series(engine, t0, q0, qd0, p [, {orders, linear}]) -> { a_0, ..., a_p } */
static int lt_motion_series(lua_State *L)
{
  lua_settop(L, 6);
  bound_system b;
  bind_recorded(L, &b, "motion_series");
  int k = b.sys.k;
  double t0 = luaL_checknumber(L, 2);
  lua_Integer p = luaL_checkinteger(L, 5);
  luaL_argcheck(L, p >= 0 && p <= 1000, 5, "order out of range (0 .. 1000)");
  double *buf = lua_newuserdatauv(L, ((size_t)p + 3) * (size_t)k * sizeof(double), 0);
  double *q0 = buf, *qd0 = buf + k, *a = buf + 2 * k;
  nz_lua_read_vector(L, 3, k, q0, "q0", 0, "motion_series");
  nz_lua_read_vector(L, 4, k, qd0, "qd0", 1, "motion_series");
  taylor_box *tb = new_box(L);
  nz_taylor_motion_config tc;
  memset(&tc, 0, sizeof tc);
  tc.rtol = tc.atol = 1e-12;
  read_setup(L, &b, lua_istable(L, 6) ? 6 : 0, "motion_series", &tc.setup);
  if (!(tb->st = nz_taylor_motion_new(&tc))) return luaL_error(L, "not enough memory for the series");
  int st = nz_taylor_motion_series(tb->st, &b.sys, t0, q0, qd0, (int)p, a);
  if (st && raise_motion(L, tb->st)) return 0;
  if (st) return raise_series(L, &b, st, t0, "motion_series");
  lua_createtable(L, (int)p + 1, 0);
  for (int n = 0; n <= p; n++) {
    nz_lua_push_vector(L, a + (size_t)n * (size_t)k, k);
    lua_rawseti(L, -2, n + 1);
  }
  return 1;
}

/* The buffered points appended to the tables t, q, qd at tidx, tidx + 1,
 * tidx + 2. */
static void flush(lua_State *L, nz_run *r, int k, int tidx)
{
  int n = nz_run_count(r);
  lua_Integer first = (lua_Integer)lua_rawlen(L, tidx) + 1;
  for (int i = 0; i < n; i++) {
    double t;
    const double *y, *acc, *root;
    nz_run_point(r, i, &t, &y, &acc, &root);
    lua_pushnumber(L, t);
    lua_rawseti(L, tidx, first + i);
    nz_lua_push_vector(L, y, k);
    lua_rawseti(L, tidx + 1, first + i);
    nz_lua_push_vector(L, y + k, k);
    lua_rawseti(L, tidx + 2, first + i);
  }
  nz_run_clear(r);
}

/* taylor_run(engine, opts) -> { t, q, qd, stats } */
static int lt_taylor_run(lua_State *L)
{
  lua_settop(L, 2);
  luaL_checktype(L, 2, LUA_TTABLE);
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int k = b.sys.k;
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = opt_number(L, 2, "t0", 0.0, "taylor_run");
  c.t1 = opt_number(L, 2, "t1", NAN, "taylor_run");
  c.dt = opt_number(L, 2, "dt", c.t1 - c.t0, "taylor_run");
  double max_steps = opt_number(L, 2, "max_steps", 0.0, "taylor_run");
  if (!isfinite(c.t0) || !isfinite(c.t1) || !(c.t1 > c.t0))
    return nz_lua_error(L, "bad argument to 'taylor_run' (t1 must be a finite number after t0)");
  if (!(c.dt > 0.0) || !isfinite(c.dt))
    return nz_lua_error(L, "bad argument to 'taylor_run' (dt must be a positive finite number)");
  if (!(max_steps >= 0.0 && max_steps == floor(max_steps) && max_steps < 1e18))
    return nz_lua_error(L, "bad argument to 'taylor_run' (max_steps must be a whole number >= 0)");
  if (!(ceil((c.t1 - c.t0) / c.dt - 1e-9) <= 1e9))
    return nz_lua_error(L, "bad argument to 'taylor_run' (the output grid t0 .. t1 by dt is too long)");
  double *y0 = lua_newuserdatauv(L, 2 * (size_t)k * sizeof(double), 0);
  lua_getfield(L, 2, "q0");
  nz_lua_read_vector(L, lua_gettop(L), k, y0, "q0", 0, "taylor_run");
  lua_getfield(L, 2, "qd0");
  nz_lua_read_vector(L, lua_gettop(L), k, y0 + k, "qd0", 1, "taylor_run");
  lua_pop(L, 2);
  taylor_box *tb = new_box(L);
  tb->st = nz_lua_taylor_new(L, 2, "taylor_run");
  c.h0 = 1.0;                        /* (Taylor's steps are its own) */
  c.stall_window = ULONG_MAX;        /* no stall detection: the step size's own check */
  double npts = ceil((c.t1 - c.t0) / c.dt - 1e-9) + 1.0;
  c.capacity = npts < 4096.0 ? (int)npts : 4096;   /* the buffer, allocated per run: no larger than the grid */
  c.dense = 1;
  c.rtol = c.atol = 1.0;             /* (the polynomial needs no tolerance) */
  c.no_accel = 1;
  if (!(tb->r = nz_run_alloc(tb->st, &c, y0))) return luaL_error(L, "not enough memory for the run");
  lua_createtable(L, 0, 4);          /* the result, then its t, q, qd */
  int res = lua_gettop(L);
  lua_newtable(L);
  lua_newtable(L);
  lua_newtable(L);
  double clock0 = nz_run_clock(), seconds = 0.0;
  for (;;) {
    int st;
    nz_run_status rs = nz_run_advance(tb->r, &b.sys, (unsigned long)max_steps, 0.0, &st);
    seconds += nz_run_clock() - clock0;
    flush(L, tb->r, k, res + 1);
    clock0 = nz_run_clock();
    if (rs == NZ_RUN_DONE) break;
    if (rs == NZ_RUN_FULL) continue;
    if (rs == NZ_RUN_INTERRUPTED) return nz_lua_raise_interrupt(L);
    char num[64];
    nz_lua_fmt_num(num, sizeof num, nz_run_time(tb->r));
    if (rs == NZ_RUN_PAUSED)
      return nz_lua_error(L, "system '%s': 'taylor_run' stopped at t = %s: max_steps reached", nz_lua_system_name(L, 1), num);
    if (rs != NZ_RUN_FAILED) return nz_lua_error(L, "system '%s': 'taylor_run' failed (%d)", nz_lua_system_name(L, 1), (int)rs);
    char what[512];
    double t;
    const char *why = failure_text(tb->st, b.comp, what, sizeof what, &t);
    if (!why && raise_motion(L, tb->st)) return 0;
    if (!why) return nz_lua_raise_core(L, &b, st ? st : NZ_EFUNC, "taylor_run");
    if (!strcmp(why, "series")) return raise_series(L, &b, st, t, "taylor_run");
    return nz_lua_error(L, "system '%s': 'taylor_run' %s", nz_lua_system_name(L, 1), what);
  }
  lua_setfield(L, res, "qd");
  lua_setfield(L, res, "q");
  lua_setfield(L, res, "t");
  nz_stepper_stats ss;
  tb->st->ops->stats(tb->st, &ss);
  double hmin, hmax;
  nz_taylor_step_sizes(tb->st, &hmin, &hmax);
  lua_createtable(L, 0, 7);
  lua_pushinteger(L, (lua_Integer)ss.steps);
  lua_setfield(L, -2, "steps");
  lua_pushinteger(L, ss.order);
  lua_setfield(L, -2, "order");
  lua_pushinteger(L, (lua_Integer)ss.nfev);
  lua_setfield(L, -2, "nfev");
  lua_pushnumber(L, hmin);
  lua_setfield(L, -2, "hmin");
  lua_pushnumber(L, hmax);
  lua_setfield(L, -2, "hmax");
  lua_pushnumber(L, nz_run_time(tb->r));
  lua_setfield(L, -2, "t");
  lua_pushnumber(L, seconds);        /* the run in C, without the Lua tables of the result */
  lua_setfield(L, -2, "seconds");
  lua_setfield(L, res, "stats");
  lua_pushvalue(L, res);
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
