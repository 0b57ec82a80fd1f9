/* lua_ode.c - the integrator (stepper.h) for Lua: a userdata "nz.ode" owning
 * a GSL stepper (ode.h), Taylor's method (taylor.h, made by lua_taylor.c)
 * or a variational integrator (variational.h, made by lua_variational.c)
 * for one system, stepped by lua/nz/motion/simulate.lua (GSL's steppers also in
 * its Lua loop, through ode_step).  Each call
 * binds the system's definition table again (the evaluator lives for one
 * call), and a failure is raised after GSL has returned, with the time, the
 * state and what went wrong. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <lauxlib.h>
#include "core/interrupt.h"
#include "lua/lua_contact.h"
#include "lua/lua_graph.h"
#include "lua/lua_ode.h"
#include "lua/lua_points.h"
#include "lua/lua_system.h"
#include "lua/lua_taylor.h"
#include "lua/lua_util.h"
#include "lua/lua_variational.h"
#include "mech/constrained.h"
#include "mech/contact.h"
#include "mech/mech_graph.h"
#include "graph/graph_rounding.h"
#include "ode/ode.h"
#include "ode/ode_run.h"
#include "ode/stepper.h"
#include "ode/taylor.h"

#define NZ_ODE_METATABLE "nz.ode"
#define NZ_RUN_METATABLE "nz.ode_run"
#define NZ_EVENTS_METATABLE "nz.ode_events"

typedef struct ode_box {
  nz_stepper *st;                    /* the integrator, owning o for GSL's */
  nz_ode *o;                         /* GSL's steppers; NULL for taylor */
  nz_contacts *contacts;             /* the unilateral contacts (user value 1), or NULL */
  int k, nc, dim;
  char method[16];
} ode_box;

static ode_box *check_ode(lua_State *L, int idx)
{
  ode_box *b = luaL_checkudata(L, idx, NZ_ODE_METATABLE);
  if (!b->st) luaL_error(L, "this integrator has been freed");
  return b;
}

/* The functions of GSL's steppers alone (a step from Lua, the right-hand
 * side, the Jacobian). */
static ode_box *check_gsl(lua_State *L, int idx)
{
  ode_box *b = check_ode(L, idx);
  if (!b->o) luaL_error(L, "method '%s' runs in the C loop only (ode_run): it has no right-hand side to step from Lua", b->method);
  return b;
}

static int ode_gc(lua_State *L)
{
  ode_box *b = luaL_checkudata(L, 1, NZ_ODE_METATABLE);
  nz_stepper_free(b->st);
  b->st = NULL;
  b->o = NULL;
  return 0;
}

/* ode_new(def, cfg) with cfg = {method, rtol, atol, h0, work, orders,
 * linear, alpha, beta, newton_tol, newton_maxit} -> ode */
static int lo_new(lua_State *L)
{
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  luaL_checktype(L, 2, LUA_TTABLE);
  int k = b.sys.k, nc = b.sys.nc;
  nz_ode_config cfg;
  memset(&cfg, 0, sizeof cfg);
  lua_getfield(L, 2, "method");
  cfg.method = luaL_optstring(L, -1, "rk8pd");
  /* unilateral contacts (lua_contact.h): kept alive as the box's user value */
  lua_getfield(L, 2, "contacts");
  int cs = lua_gettop(L);
  cfg.contacts = nz_lua_tocontacts(L, cs);
  if (!lua_isnil(L, cs) && !cfg.contacts) return luaL_error(L, "internal: 'contacts' is not an nz.contacts");
  int taylor = !strcmp(cfg.method, "taylor");
  if (taylor || !strcmp(cfg.method, "variational")) {
    /* Taylor's method and the variational integrators: lua_taylor.c and
     * lua_variational.c check and make them */
    ode_box *box = lua_newuserdatauv(L, sizeof *box, 1);
    memset(box, 0, sizeof *box);
    luaL_setmetatable(L, NZ_ODE_METATABLE);
    lua_pushvalue(L, cs);
    lua_setiuservalue(L, -2, 1);
    box->k = k;
    box->nc = nc;
    box->dim = 2 * k;
    box->contacts = cfg.contacts;
    snprintf(box->method, sizeof box->method, "%s", cfg.method);
    box->st = taylor ? nz_lua_taylor_new(L, 2, "simulate") : nz_lua_variational_new(L, 2);
    return 1;
  }
  int known = 0;
  for (int i = 0; nz_ode_methods[i]; i++) known |= !strcmp(nz_ode_methods[i], cfg.method);
  if (!known) {
    luaL_Buffer msg;
    luaL_buffinit(L, &msg);
    lua_pushfstring(L, "unknown method '%s'; GSL's steppers are:", cfg.method);
    luaL_addvalue(&msg);
    for (int i = 0; nz_ode_methods[i]; i++) {
      luaL_addstring(&msg, " ");
      luaL_addstring(&msg, nz_ode_methods[i]);
    }
    luaL_pushresult(&msg);
    return nz_lua_raise_located(L);
  }
  cfg.rtol = nz_lua_field_number(L, 2, "rtol", 1e-10);
  cfg.atol = nz_lua_field_number(L, 2, "atol", 1e-12);
  cfg.h0 = nz_lua_field_number(L, 2, "h0", 1e-3);
  lua_getfield(L, 2, "work");
  cfg.work = lua_toboolean(L, -1);
  lua_pop(L, 1);
  cfg.level = (int)nz_lua_field_number(L, 2, "level", 0.0);
  lua_getfield(L, 2, "top");
  cfg.top = lua_toboolean(L, -1);
  lua_pop(L, 1);
  cfg.nc = nc;
  lua_getfield(L, 2, "guess");       /* top: Newton's first start (q^(p), lambda) */
  if (!lua_isnil(L, -1)) {
    double *g = lua_newuserdatauv(L, ((size_t)k + (size_t)nc + 1) * sizeof(double), 0);
    nz_lua_read_vector(L, lua_gettop(L) - 1, k + nc, g, "guess", 0, "simulate");
    cfg.guess = g;                   /* kept on the stack until nz_ode_alloc copies it */
  }
  int *flags = lua_newuserdatauv(L, 2 * ((size_t)nc + 1) * sizeof(int), 0);
  nz_lua_field_ints(L, 2, "orders", nc, flags);
  nz_lua_field_ints(L, 2, "linear", nc, flags + nc + 1);
  cfg.orders = flags;
  cfg.linear = flags + nc + 1;
  nz_accel_options acc = NZ_ACCEL_DEFAULTS;
  acc.baumgarte_alpha = nz_lua_field_number(L, 2, "alpha", 0.0);
  acc.baumgarte_beta = nz_lua_field_number(L, 2, "beta", 0.0);
  acc.newton_tol = nz_lua_field_number(L, 2, "newton_tol", acc.newton_tol);
  acc.newton_maxit = (int)nz_lua_field_number(L, 2, "newton_maxit", acc.newton_maxit);
  acc.rcond_min = nz_lua_field_number(L, 2, "rcond_min", acc.rcond_min);
  lua_getfield(L, 2, "check");              /* false: trust every solve (to measure the check) */
  acc.skip_check = lua_isboolean(L, -1) && !lua_toboolean(L, -1);
  lua_pop(L, 1);
  cfg.accel = acc;
  ode_box *box = lua_newuserdatauv(L, sizeof *box, 1);
  memset(box, 0, sizeof *box);
  luaL_setmetatable(L, NZ_ODE_METATABLE);
  lua_pushvalue(L, cs);
  lua_setiuservalue(L, -2, 1);
  box->k = k;
  box->nc = nc;
  box->contacts = cfg.contacts;
  snprintf(box->method, sizeof box->method, "%s", cfg.method);
  nz_ode *o = nz_ode_alloc(k, &cfg);
  if (!o || !(box->st = nz_stepper_gsl_new(o, k, nc, cfg.rtol, cfg.atol)))
    return luaL_error(L, "not enough memory for the integrator");
  box->o = o;
  box->dim = nz_ode_dim(o);
  return 1;
}

/* Raise the failure of the last step or evaluation, with time and state. */
static int raise_failure(lua_State *L, ode_box *box, bound_system *b, int st)
{
  if (nz_lua_contacts_failed(box->contacts) && !b->ev.interrupted)   /* a contact mode's solve */
    return nz_lua_contacts_raise(L, box->contacts, b);
  if (!box->o) {
    if (b->ev.interrupted) return nz_lua_raise_interrupt(L);
    if (!strcmp(box->method, "variational")) return nz_lua_variational_raise(L, b, box->st, st);
    return nz_lua_taylor_raise(L, box->st, st);
  }
  const nz_ode_failure *f = nz_ode_last_failure(box->o);
  int k = box->k;
  const double *q = f->y, *qd = f->y ? f->y + k : NULL;
  if (b->ev.interrupted || (f->kind == NZ_ODE_FAIL_FUNCTION && nz_interrupt_requested()))
    return nz_lua_raise_interrupt(L);
  switch (f->kind) {
  case NZ_ODE_FAIL_MASS:
    return nz_lua_raise_singular_mass(L, 1, f->t, q, qd, k, &f->mass);
  case NZ_ODE_FAIL_CONSTRAINTS:
    return nz_lua_raise_accel_failure(L, 1, &f->accel, nz_ode_orders(box->o), f->t, q, qd, k, box->nc);
  case NZ_ODE_FAIL_STEP:
  case NZ_ODE_FAIL_NONFINITE: {
    luaL_Buffer msg;
    luaL_buffinit(L, &msg);
    lua_pushfstring(L, "system '%s': ", nz_lua_system_name(L, 1));
    luaL_addvalue(&msg);
    if (f->kind == NZ_ODE_FAIL_STEP)
      lua_pushfstring(L, "the integrator (%s) could not make a step (GSL status %d): the step "
                      "size fell below what the tolerance allows, or the motion is singular", box->method, f->status);
    else
      lua_pushfstring(L, "the state became NaN or infinite (method %s)", box->method);
    luaL_addvalue(&msg);
    nz_lua_add_state(&msg, f->t, q, qd, k);
    luaL_addstring(&msg, ": check the system near this state, or change the method or the tolerances");
    luaL_pushresult(&msg);
    return nz_lua_raise_located(L);
  }
  default:
    return nz_lua_raise_core(L, b, st ? st : NZ_EFUNC, "simulate");
  }
}

static void read_y(lua_State *L, int idx, ode_box *box, double *y)
{
  nz_lua_read_vector(L, idx, box->dim, y, "y", 0, "simulate");
}

/* The start of every call (ode, def, ...): check the integrator, put def
 * first (as the binding expects; the caller keeps ode alive), bind it, and
 * read the state y at idx into scratch with `extra` more doubles. */
static ode_box *begin_call(lua_State *L, int nargs, bound_system *b, int idx, size_t extra, double **y)
{
  lua_settop(L, nargs);
  ode_box *box = check_ode(L, 1);
  lua_copy(L, 2, 1);
  nz_lua_bind_system(L, 1, b);
  int dim = box->dim;
  *y = lua_newuserdatauv(L, ((size_t)dim + extra) * sizeof(double), 0);
  read_y(L, idx, box, *y);
  return box;
}

/* ode_step(ode, def, t, t1, h, y) -> t, h, y (a new table) */
static int lo_step(lua_State *L)
{
  bound_system b;
  double *y;
  check_gsl(L, 1);
  ode_box *box = begin_call(L, 6, &b, 6, 0, &y);
  double t = luaL_checknumber(L, 3), t1 = luaL_checknumber(L, 4), h = luaL_checknumber(L, 5);
  int dim = box->dim;
  int st = nz_ode_step(box->o, &b.sys, &t, t1, &h, y);
  if (st) return raise_failure(L, box, &b, st);
  lua_pushnumber(L, t);
  lua_pushnumber(L, h);
  nz_lua_push_vector(L, y, dim);
  return 3;
}

/* ode_step_fixed(ode, def, t, h, y) -> t, y */
static int lo_step_fixed(lua_State *L)
{
  bound_system b;
  double *y;
  check_gsl(L, 1);
  ode_box *box = begin_call(L, 5, &b, 5, 0, &y);
  double t = luaL_checknumber(L, 3), h = luaL_checknumber(L, 4);
  int dim = box->dim;
  int st = nz_ode_step_fixed(box->o, &b.sys, &t, h, y);
  if (st) return raise_failure(L, box, &b, st);
  lua_pushnumber(L, t);
  nz_lua_push_vector(L, y, dim);
  return 2;
}

/* ode_rhs(ode, def, t, y) -> f: the right-hand side the steppers see */
static int lo_rhs(lua_State *L)
{
  bound_system b;
  double *y;
  lua_settop(L, 4);
  int dim = check_gsl(L, 1)->dim;
  ode_box *box = begin_call(L, 4, &b, 4, (size_t)dim, &y);
  double t = luaL_checknumber(L, 3);
  int st = nz_ode_rhs(box->o, &b.sys, t, y, y + dim);
  if (st) return raise_failure(L, box, &b, st);
  nz_lua_push_vector(L, y + dim, dim);
  return 1;
}

/* ode_accel(ode, def, t, y) -> qdd, lambda[, q^(p) of a top integrator] */
static int lo_accel(lua_State *L)
{
  bound_system b;
  double *y;
  lua_settop(L, 4);
  ode_box *box = check_ode(L, 1);
  int k = box->k, nc = box->nc;
  box = begin_call(L, 4, &b, 4, (size_t)k + (size_t)nc, &y);
  double t = luaL_checknumber(L, 3);
  int dim = box->dim;
  int st = box->st->ops->accel(box->st, &b.sys, t, y, y + dim);
  if (st) return raise_failure(L, box, &b, st);
  nz_lua_push_vector(L, y + dim, k);
  nz_lua_push_vector(L, y + dim + k, nc);
  const double *root = box->st->ops->root(box->st);
  if (!root) return 2;
  nz_lua_push_vector(L, root, k);
  return 3;
}

/* ode_jacobian(ode, def, t, y) -> dfdy (rows), dfdt: the exact Jacobian the
 * implicit steppers use (exposed for tests and for users who want it). */
static int lo_jacobian(lua_State *L)
{
  bound_system b;
  double *y;
  lua_settop(L, 4);
  int dim = check_gsl(L, 1)->dim;
  ode_box *box = begin_call(L, 4, &b, 4, (size_t)dim * (size_t)dim + (size_t)dim, &y);
  double t = luaL_checknumber(L, 3);
  double *J = y + dim, *dfdt = J + (size_t)dim * dim;
  int st = nz_ode_jacobian_at(box->o, &b.sys, t, y, J, dfdt);
  if (st) return raise_failure(L, box, &b, st);
  lua_createtable(L, dim, 0);
  for (int i = 0; i < dim; i++) {
    nz_lua_push_vector(L, J + (size_t)i * dim, dim);
    lua_rawseti(L, -2, i + 1);
  }
  nz_lua_push_vector(L, dfdt, dim);
  return 2;
}

static int lo_reset(lua_State *L)
{
  nz_stepper *st = check_ode(L, 1)->st;
  st->ops->reset(st);
  return 0;
}

/* ode_stats(ode) -> { steps, rejected, nfev, njev, order [, reversed] }: the
 * interface's statistics (Taylor: nfev counts the series of the motion,
 * order the highest used). */
static int lo_stats(lua_State *L)
{
  nz_stepper_stats st;
  nz_stepper *sp = check_ode(L, 1)->st;
  sp->ops->stats(sp, &st);
  lua_createtable(L, 0, 5);
  lua_pushinteger(L, st.order);
  lua_setfield(L, -2, "order");
  lua_pushinteger(L, (lua_Integer)st.steps);
  lua_setfield(L, -2, "steps");
  lua_pushinteger(L, (lua_Integer)st.rejected);
  lua_setfield(L, -2, "rejected");
  lua_pushinteger(L, (lua_Integer)st.nfev);
  lua_setfield(L, -2, "nfev");
  lua_pushinteger(L, (lua_Integer)st.njev);
  lua_setfield(L, -2, "njev");
  if (st.reversed) {   /* { constraint, ta, tb }: a gradient passed through zero */
    lua_createtable(L, 3, 0);
    lua_pushinteger(L, st.reversed);
    lua_rawseti(L, -2, 1);
    lua_pushnumber(L, st.reversed_ta);
    lua_rawseti(L, -2, 2);
    lua_pushnumber(L, st.reversed_tb);
    lua_rawseti(L, -2, 3);
    lua_setfield(L, -2, "reversed");
  }
  return 1;
}

/* ------------------------------------------------------------------ */
/* The loop in C (ode_run.h): a userdata "nz.ode_run" that keeps its
 * integrator alive (its user value) and steps it until simulate.lua must
 * act.  A failure or the interrupt is raised exactly as ode_step and
 * ode_accel raise it, the points computed before it handed over to the
 * trajectory first (flush_points below). */

/* ------------------------------------------------------------------ */
/* Event functions recorded as graphs (lua/nz/model/record.lua's
 * state_functions): a userdata "nz.ode_events" with one plan on doubles per
 * event, its inputs numbered as mech_graph.h says (0 = t, 1..np the
 * parameters, then slot j of q_i at 1 + np + j k + i, j = 0, 1), and the
 * recording (an nz.recording) kept alive as its user value.  Both loops of
 * simulate.lua take an event's value from here, so that they see the same
 * numbers; where a plan fails (a domain error at this state) the event's
 * Lua function gives the value, or the error with the user's line. */

typedef struct events_box {
  int n, k, np;
  nz_graph_plan **plans;
  double *in;
} events_box;

static int events_gc(lua_State *L)
{
  events_box *eb = luaL_checkudata(L, 1, NZ_EVENTS_METATABLE);
  for (int e = 0; eb->plans && e < eb->n; e++) nz_graph_plan_free(eb->plans[e]);
  free(eb->plans);
  free(eb->in);
  eb->plans = NULL;
  eb->in = NULL;
  return 0;
}

/* ode_events_new(recording, {node per event}, {parameter values}, k) -> events */
static int lo_events_new(lua_State *L)
{
  nz_recording *c = nz_lua_torecording(L, 1);
  luaL_argcheck(L, c != NULL, 1, "a recording (nz.recording) expected");
  luaL_checktype(L, 2, LUA_TTABLE);
  luaL_checktype(L, 3, LUA_TTABLE);
  int k = (int)luaL_checkinteger(L, 4);
  nz_graph *g = nz_recording_graph(c);
  int n = (int)luaL_len(L, 2), np = (int)luaL_len(L, 3);
  luaL_argcheck(L, np == nz_recording_nparams(c), 3, "one value per recorded parameter expected");
  events_box *eb = lua_newuserdatauv(L, sizeof *eb, 1);
  memset(eb, 0, sizeof *eb);
  luaL_setmetatable(L, NZ_EVENTS_METATABLE);
  lua_pushvalue(L, 1);
  lua_setiuservalue(L, -2, 1);
  eb->k = k;
  eb->np = np;
  eb->plans = calloc((size_t)n + 1, sizeof *eb->plans);
  eb->in = calloc((size_t)(1 + np + 2 * k) + (size_t)nz_graph_ninputs(g), sizeof(double));
  if (!eb->plans || !eb->in) return luaL_error(L, "not enough memory for the events");
  eb->n = n;
  for (int e = 0; e < n; e++) {
    lua_geti(L, 2, e + 1);
    lua_Integer id = luaL_checkinteger(L, -1);
    lua_pop(L, 1);
    if (id < 0 || id >= nz_graph_size(g)) return luaL_error(L, "internal: event %d: node %d is not in the graph", e + 1, (int)id);
    int node = (int)id;
    if (!(eb->plans[e] = nz_graph_plan_new(g, &node, 1))) return luaL_error(L, "not enough memory for the events");
  }
  for (int p = 0; p < np; p++) {
    lua_geti(L, 3, p + 1);
    eb->in[1 + p] = luaL_checknumber(L, -1);
    lua_pop(L, 1);
  }
  return 1;
}

/* Event e's value at (t, y) (y: q then qd, at least 2k values) from its plan. */
static int events_eval(events_box *eb, int e, double t, const double *y, double *g)
{
  double *in = eb->in;
  in[0] = t;
  memcpy(in + 1 + eb->np, y, 2 * (size_t)eb->k * sizeof(double));
  return nz_graph_eval(eb->plans[e], in, g);
}

/* ode_event_value(events, e (1-based), t, y) -> g, or nil where the graph
 * fails (the caller then asks the event's Lua function). */
static int lo_event_value(lua_State *L)
{
  events_box *eb = luaL_checkudata(L, 1, NZ_EVENTS_METATABLE);
  int e = (int)luaL_checkinteger(L, 2) - 1;
  luaL_argcheck(L, eb->plans && e >= 0 && e < eb->n, 2, "no such event");
  double t = luaL_checknumber(L, 3), g;
  double *y = lua_newuserdatauv(L, 2 * (size_t)eb->k * sizeof(double) + 1, 0);
  luaL_checktype(L, 4, LUA_TTABLE);
  for (int i = 0; i < 2 * eb->k; i++) {   /* q, qd: the start of a state that may hold more */
    lua_geti(L, 4, i + 1);
    y[i] = luaL_checknumber(L, -1);
    lua_pop(L, 1);
  }
  if (events_eval(eb, e, t, y, &g)) lua_pushnil(L);
  else lua_pushnumber(L, g);
  return 1;
}

/* ode_run_violation(def, {orders}, t, y) -> the violation nz_run computes
 * (nz_state_violation), for the tests that hold it to constraints.violation. */
static int lo_run_violation(lua_State *L)
{
  lua_settop(L, 4);
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int k = b.sys.k, nc = b.sys.nc;
  int *orders = lua_newuserdatauv(L, ((size_t)nc + 1) * sizeof(int), 0);
  for (int r = 0; r < nc; r++) {
    lua_geti(L, 2, r + 1);
    orders[r] = (int)luaL_checkinteger(L, -1);
    lua_pop(L, 1);
  }
  double t = luaL_checknumber(L, 3), v;
  double *y = lua_newuserdatauv(L, 2 * (size_t)k * sizeof(double) + 1, 0);
  nz_lua_read_vector(L, 4, 2 * k, y, "y", 0, "simulate");
  int st = nz_state_violation(&b.sys, orders, t, y, y + k, &v);
  if (st) return nz_lua_raise_core(L, &b, st, "constraint_partials");
  lua_pushnumber(L, v);
  return 1;
}

typedef struct run_box {
  nz_run *r;
  ode_box *ode, *locator;            /* (kept alive as user values 1 and 5) */
  events_box *events;                /* NULL: none recorded (user value 2) */
  int nuser;                         /* the user's events; the contacts' follow */
  int *orders;                       /* nc: the violation in C (NULL: none, or in Lua) */
} run_box;

/* The hooks of one ode_run call (ode_run.h): an event's value from its
 * graph, else from the Lua fallback (at stack index fallback), a contact's
 * from the contacts; the violation in C, or from the Lua function at stack
 * index violation.  A Lua function runs under lua_pcall, and its error is
 * kept at stack index err for ode_run to raise once the C loop has
 * returned (a Lua error never unwinds through the C core). */
typedef struct hook_ctx {
  lua_State *L;
  run_box *rb;
  int fallback, violation, err, failed;
  const nz_system *s;
} hook_ctx;

/* Call the Lua function at stack index fn with (e + 1 unless e < 0, t, y):
 * its number, or NZ_EFUNC with its error kept. */
static int call_lua(hook_ctx *c, int fn, int e, double t, const double *y, double *out)
{
  lua_State *L = c->L;
  if (!lua_checkstack(L, 5)) return NZ_ENOMEM;
  lua_pushvalue(L, fn);
  if (e >= 0) lua_pushinteger(L, e + 1);
  lua_pushnumber(L, t);
  nz_lua_push_vector(L, y, c->rb->ode->dim);
  if (lua_pcall(L, e >= 0 ? 3 : 2, 1, 0) != LUA_OK) {
    lua_replace(L, c->err);
    c->failed = 1;
    return NZ_EFUNC;
  }
  *out = lua_tonumber(L, -1);
  lua_pop(L, 1);
  return NZ_OK;
}

static int run_event(void *ctx, int e, double t, const double *y, double *g)
{
  hook_ctx *c = ctx;
  run_box *rb = c->rb;
  if (e >= rb->nuser) return nz_contacts_event(rb->ode->contacts, c->s, e - rb->nuser, t, y, g);
  if (rb->events && events_eval(rb->events, e, t, y, g) == NZ_OK) return NZ_OK;
  if (lua_isnil(c->L, c->fallback)) return NZ_EDOM;   /* none: the graph's failure fails the run */
  return call_lua(c, c->fallback, e, t, y, g);
}

static int run_violation(void *ctx, double t, const double *y, double *v)
{
  hook_ctx *c = ctx;
  if (c->rb->orders) return nz_state_violation(c->s, c->rb->orders, t, y, y + c->rb->ode->k, v);
  if (lua_isnil(c->L, c->violation)) {   /* no constraints: nothing to violate */
    *v = 0.0;
    return NZ_OK;
  }
  return call_lua(c, c->violation, -1, t, y, v);
}

static run_box *check_run(lua_State *L, int idx)
{
  run_box *rb = luaL_checkudata(L, idx, NZ_RUN_METATABLE);
  if (!rb->r) luaL_error(L, "this run has been freed");
  return rb;
}

static int run_gc(lua_State *L)
{
  run_box *rb = luaL_checkudata(L, 1, NZ_RUN_METATABLE);
  nz_run_free(rb->r);                /* never touches the integrator */
  rb->r = NULL;
  return 0;
}


/* ode_run_new(ode, {t0, t1, dt, step, h0, y, stall_window, stall_fraction
 * [, capacity] [, events, directions, fallback, locator, event_tol]
 * [, project_tol, orders | violation] [, dense, rtol, atol]}) -> run.
 * events: an nz.ode_events (the recorded graphs), or nil when none is
 * recorded; directions: one per user event (0, 1, -1); fallback(e, t, y):
 * event e's value where its graph fails or is absent (it raises the
 * event's error; nil: the graph's failure fails the run); locator: an
 * nz.ode that integrates a step again to locate an event where the dense
 * output misses the tolerance (required with events, unless the method's
 * dense output is exact); project_tol > 0: return "project" when the
 * violation exceeds it, computed in C from the constraints' orders, or by
 * violation(t, y). */
static int lo_run_new(lua_State *L)
{
  lua_settop(L, 2);
  ode_box *ob = check_ode(L, 1);
  luaL_checktype(L, 2, LUA_TTABLE);
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = nz_lua_field_number(L, 2, "t0", 0.0);
  c.t1 = nz_lua_field_number(L, 2, "t1", 0.0);
  c.dt = nz_lua_field_number(L, 2, "dt", 0.0);
  c.step = nz_lua_field_number(L, 2, "step", 0.0);
  c.h0 = nz_lua_field_number(L, 2, "h0", 1e-3);
  c.stall_window = (unsigned long)nz_lua_field_number(L, 2, "stall_window", 1000.0);
  c.stall_fraction = nz_lua_field_number(L, 2, "stall_fraction", 1e-10);
  c.capacity = (int)nz_lua_field_number(L, 2, "capacity", 1024.0);
  c.project_tol = nz_lua_field_number(L, 2, "project_tol", 0.0);
  c.rtol = nz_lua_field_number(L, 2, "rtol", 0.0);
  c.atol = nz_lua_field_number(L, 2, "atol", 0.0);
  c.event_tol = nz_lua_field_number(L, 2, "event_tol", 1e-12);
  lua_getfield(L, 2, "dense");
  c.dense = lua_toboolean(L, -1);
  lua_pop(L, 1);
  lua_getfield(L, 2, "events");                            /* at 3 */
  events_box *eb = lua_isnil(L, 3) ? NULL : luaL_checkudata(L, 3, NZ_EVENTS_METATABLE);
  lua_getfield(L, 2, "fallback");                          /* at 4 */
  if (!lua_isnil(L, 4)) luaL_checktype(L, 4, LUA_TFUNCTION);
  lua_getfield(L, 2, "violation");                         /* at 5 */
  if (!lua_isnil(L, 5)) luaL_checktype(L, 5, LUA_TFUNCTION);
  lua_getfield(L, 2, "locator");                           /* at 6 */
  ode_box *loc = lua_isnil(L, 6) ? NULL : check_ode(L, 6);
  lua_getfield(L, 2, "directions");
  int nuser = lua_istable(L, -1) ? (int)luaL_len(L, -1) : 0;
  lua_pop(L, 1);
  if (eb && eb->n != nuser) return luaL_error(L, "internal: %d directions for %d recorded events", nuser, eb->n);
  if (nuser > 0 && !eb && lua_isnil(L, 4)) return luaL_error(L, "internal: events without graphs need a fallback");
  /* the contacts' events follow the user's, each falling through zero */
  int ncontact = ob->contacts ? nz_contacts_nevents(ob->contacts) : 0;
  c.nevents = nuser + ncontact;
  int *dirs = lua_newuserdatauv(L, ((size_t)c.nevents + 1) * sizeof(int), 0);
  nz_lua_field_ints(L, 2, "directions", nuser, dirs);
  for (int e = nuser; e < c.nevents; e++) dirs[e] = -1;
  c.directions = dirs;
  c.locator = loc ? loc->st : NULL;
  int in_c = c.project_tol > 0.0 && lua_isnil(L, 5) && ob->nc > 0;   /* the violation computed in C */
  int *orders = lua_newuserdatauv(L, ((size_t)ob->nc + 1) * sizeof(int), 0);
  if (in_c) nz_lua_field_ints(L, 2, "orders", ob->nc, orders);
  int dim = ob->dim;
  double *y = lua_newuserdatauv(L, (size_t)dim * sizeof(double), 0);
  lua_getfield(L, 2, "y");
  nz_lua_read_vector(L, lua_gettop(L), dim, y, "y", 0, "simulate");
  lua_pop(L, 1);
  run_box *rb = lua_newuserdatauv(L, sizeof *rb + ((size_t)ob->nc + 1) * sizeof(int), 6);
  memset(rb, 0, sizeof *rb);
  luaL_setmetatable(L, NZ_RUN_METATABLE);
  for (int u = 1; u <= 5; u++) {                           /* ode, events, fallback, violation, locator */
    lua_pushvalue(L, u == 1 ? 1 : u + 1);
    lua_setiuservalue(L, -2, u);
  }
  rb->ode = ob;
  rb->locator = loc;
  rb->events = eb;
  rb->nuser = nuser;
  if (in_c) {
    rb->orders = (int *)(void *)(rb + 1);
    memcpy(rb->orders, orders, (size_t)ob->nc * sizeof(int));
  }
  if (!(rb->r = nz_run_alloc(ob->st, &c, y)))
    return nz_lua_error(L, "simulate: the run could not start (no memory, or a bad grid: t0 = %f, t1 = %f, dt = %f, step = %f)",
                      c.t0, c.t1, c.dt, c.step);
  return 1;
}

/* The buffered points appended to the trajectory (at stack index tr): t to
 * tr.t, q, q', q'' and lambda to its points in C (tr._points, lua_points.h:
 * trajectory.lua makes a point's tables, tr.q[i] and the others, only when
 * they are read; a table per point cost 100 times the run of a Henon-Heiles
 * with 200,001 output points); when pend is a table, each point's state y
 * and root q^(p) (false when none) to pend.y[n] and pend.root[n], for what
 * run.lua records in Lua; then the buffer is emptied.  No Lua function runs
 * here, so Ctrl-C's hook cannot fire in the middle: a point is handed over
 * whole or not at all. */
static void flush_points(lua_State *L, run_box *rb, int tr, int pend)
{
  int k = rb->ode->k, nc = rb->ode->nc, dim = rb->ode->dim, count = nz_run_count(rb->r);
  int base = lua_gettop(L);
  nz_points *points = nz_lua_points_of(L, tr, k, nc);
  if (lua_getfield(L, tr, "t") != LUA_TTABLE) luaL_error(L, "simulate: tr.t is not a table");   /* base + 1 */
  int with_pend = lua_istable(L, pend);
  if (with_pend) {                   /* at base + 2, base + 3 */
    lua_getfield(L, pend, "y");
    lua_getfield(L, pend, "root");
    luaL_checktype(L, base + 2, LUA_TTABLE);
    luaL_checktype(L, base + 3, LUA_TTABLE);
  }
  lua_Integer first = (lua_Integer)lua_rawlen(L, base + 1) + 1;
  for (int i = 0; i < count; i++) {
    double t;
    const double *y, *acc, *root;
    nz_run_point(rb->r, i, &t, &y, &acc, &root);
    lua_Integer n = first + i;
    if (with_pend) {                 /* first: a point in tr has its y in pend */
      nz_lua_push_vector(L, y, dim);
      lua_rawseti(L, base + 2, n);
      if (root) nz_lua_push_vector(L, root, k);
      else lua_pushboolean(L, 0);
      lua_rawseti(L, base + 3, n);
    }
    nz_lua_points_push(L, points, y, acc);
    lua_pushnumber(L, t);            /* last: #tr.t counts whole points */
    lua_rawseti(L, base + 1, n);
  }
  nz_run_clear(rb->r);
  lua_settop(L, base);
}

/* The failure of a run's hook or of its locator, raised (the points
 * computed before it were handed over). */
static int raise_run_failure(lua_State *L, run_box *rb, bound_system *b, hook_ctx *hc, int st)
{
  nz_run_failure f = nz_run_failure_of(rb->r);
  if (hc->failed) {                  /* a Lua function's error, as it raised it */
    lua_pushvalue(L, hc->err);
    return lua_error(L);
  }
  if (f == NZ_RUN_FAIL_LOCATOR) return raise_failure(L, rb->locator, b, st);
  if (f == NZ_RUN_FAIL_VIOLATION) return nz_lua_raise_core(L, b, st, "constraint_partials");
  if (f != NZ_RUN_FAIL_EVENT) return raise_failure(L, rb->ode, b, st);
  if (nz_lua_contacts_failed(rb->ode->contacts)) return nz_lua_contacts_raise(L, rb->ode->contacts, b);
  int e;
  double ta;
  nz_run_failed_event(rb->r, &e, &ta);
  if (e < rb->nuser && lua_isnil(L, hc->fallback)) {   /* no fallback (taylor): the step and the event */
    char num[64];
    nz_lua_fmt_num(num, sizeof num, ta);
    lua_createtable(L, 0, 2);
    lua_pushliteral(L, "hook");
    lua_setfield(L, -2, "taylor_stop");
    lua_pushfstring(L, "stopped in the step from t = %s: event %d's recorded function failed (a domain error, "
                    "or not finite) on the step's polynomial", num, e + 1);
    lua_setfield(L, -2, "message");
    return lua_error(L);
  }
  return nz_lua_error(L, "simulate: event %d could not be evaluated in the step from t = %g (status %d)", e + 1, ta, st);
}

/* ode_run(run, def, tr, pend, pause_step, pause_wall) -> "done" | "paused" |
 * "full" | "stalled", advance | "project" | "event", e, te, ye, dir (an
 * event located in the last step, 1-based, rising (1) or falling (-1)):
 * steps until simulate.lua must act, hands the output points over
 * (flush_points) and raises the interrupt and failures as ode_step does
 * (an event's error as its Lua function raised it, a violation's as
 * constraint_partials does), the points computed before them handed over
 * first. */
/* The head of a call (run, def, a3, a4): the stack made 1 def (as
 * raise_failure expects; the caller keeps run), 2 def, 3, 4 the arguments,
 * 5 the events' fallback, 6 the violation's Lua function, 7 the place of a
 * Lua function's error; the system bound into b and the hooks set on the
 * run with hc (which lives on the caller's stack: the caller clears them). */
static void begin_run_call(lua_State *L, run_box *rb, bound_system *b, hook_ctx *hc)
{
  lua_settop(L, 4);
  lua_getiuservalue(L, 1, 3);
  lua_getiuservalue(L, 1, 4);
  lua_pushnil(L);
  lua_copy(L, 2, 1);
  nz_lua_bind_system(L, 1, b);
  *hc = (hook_ctx){ L, rb, 5, 6, 7, 0, &b->sys };
  nz_run_hooks hooks = { run_event, run_violation, hc };
  nz_run_set_hooks(rb->r, &hooks);
}

static int lo_run(lua_State *L)
{
  run_box *rb = check_run(L, 1);
  luaL_checktype(L, 3, LUA_TTABLE);
  lua_Integer pause_step = luaL_optinteger(L, 5, 0);
  double pause_wall = luaL_optnumber(L, 6, 0.0);
  bound_system b;
  hook_ctx hc;
  begin_run_call(L, rb, &b, &hc);
  int st;
  nz_run_status rs = nz_run_advance(rb->r, &b.sys, pause_step > 0 ? (unsigned long)pause_step : 0, pause_wall, &st);
  nz_run_set_hooks(rb->r, NULL);     /* hc dies with this call */
  flush_points(L, rb, 3, 4);
  switch (rs) {
  case NZ_RUN_INTERRUPTED: return nz_lua_raise_interrupt(L);
  case NZ_RUN_FAILED: return raise_run_failure(L, rb, &b, &hc, st);
  case NZ_RUN_STALLED:
    lua_pushliteral(L, "stalled");
    lua_pushnumber(L, nz_run_stall_advance(rb->r));
    return 2;
  case NZ_RUN_PAUSED: lua_pushliteral(L, "paused"); return 1;
  case NZ_RUN_FULL: lua_pushliteral(L, "full"); return 1;
  case NZ_RUN_PROJECT: lua_pushliteral(L, "project"); return 1;
  case NZ_RUN_EVENT: {
    int e, dir;
    double te;
    const double *ye;
    nz_run_located(rb->r, &e, &te, &ye, &dir);
    lua_pushliteral(L, "event");
    lua_pushinteger(L, e + 1);
    lua_pushnumber(L, te);
    nz_lua_push_vector(L, ye, rb->ode->dim);
    lua_pushinteger(L, dir);
    return 5;
  }
  case NZ_RUN_DONE: break;
  }
  lua_pushliteral(L, "done");
  return 1;
}

/* ode_run_jump(run, def, te, y): the motion jumps at te to y (an impact, a
 * contact's change: nz_run_jump); the events' values are taken there. */
static int lo_run_jump(lua_State *L)
{
  run_box *rb = check_run(L, 1);
  double te = luaL_checknumber(L, 3);
  int dim = rb->ode->dim;
  double *y = lua_newuserdatauv(L, (size_t)dim * sizeof(double), 0);
  nz_lua_read_vector(L, 4, dim, y, "y", 0, "simulate");
  lua_replace(L, 4);                 /* (kept alive at 4) */
  bound_system b;
  hook_ctx hc;
  begin_run_call(L, rb, &b, &hc);
  int st = nz_run_jump(rb->r, &b.sys, te, y);
  nz_run_set_hooks(rb->r, NULL);
  if (st == NZ_EARG) return nz_lua_error(L, "simulate: the run could not go on from t = %f (status %d)", te, st);
  if (st) return raise_run_failure(L, rb, &b, &hc, st);
  return 0;
}

/* ode_run_set_state(run, y): the projected state of the last step. */
static int lo_run_set_state(lua_State *L)
{
  run_box *rb = check_run(L, 1);
  int dim = rb->ode->dim;
  double *y = lua_newuserdatauv(L, (size_t)dim * sizeof(double), 0);
  nz_lua_read_vector(L, 2, dim, y, "y", 0, "simulate");
  nz_run_set_state(rb->r, y);
  return 0;
}

/* ode_run_dense(run) -> interpolated, forced: the output points read from
 * the interpolant, and those its error control made step ends. */
static int lo_run_dense(lua_State *L)
{
  run_box *rb = check_run(L, 1);
  unsigned long a, b;
  nz_run_dense_stats(rb->r, &a, &b);
  lua_pushinteger(L, (lua_Integer)a);
  lua_pushinteger(L, (lua_Integer)b);
  return 2;
}

/* ode_run_native(run) -> n: the first step of machine code throughout
 * (1: all of them), 0 none, -1 no machine code (nz_run_native_from). */
static int lo_run_native(lua_State *L)
{
  lua_pushinteger(L, (lua_Integer)nz_run_native_from(check_run(L, 1)->r));
  return 1;
}

/* ode_run_state(run) -> t, y, steps: where the run is. */
static int lo_run_state(lua_State *L)
{
  run_box *rb = check_run(L, 1);
  lua_pushnumber(L, nz_run_time(rb->r));
  nz_lua_push_vector(L, nz_run_state(rb->r), rb->ode->dim);
  lua_pushinteger(L, (lua_Integer)nz_run_steps(rb->r));
  return 3;
}

/* ode_rounding_branch(def, t, q, qd, qdd, tol) -> nil | {piece,
 * constraint, op, fn, value, bound, a, b, rounding}: the first branch of
 * the recording whose choice is decided by rounding at the state, or whose
 * deciding number lies within tol of its switch (graph_rounding.h): the
 * pieces whose functions hold it ("V", "Q", "constraint", ... joined by
 * " and "), the operation (a node op's name; fn the function's or the
 * comparison's number), the number that decides it and its rounding bound,
 * the branch's operands, and whether rounding decides it.  For a run
 * whose steps collapsed (advice.lua). */
static int lo_rounding_branch(lua_State *L)
{
  static const char *const names[NZ_PIECE_COUNT] = { "T", "T", "V", "Q", "S", "constraint" };
  lua_settop(L, 6);
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  if (!b.comp) return 0;
  int k = b.sys.k;
  double t = luaL_checknumber(L, 2), tol = luaL_optnumber(L, 6, 0.0);
  double *y = lua_newuserdatauv(L, 3 * (size_t)k * sizeof(double), 0);
  nz_lua_read_vector(L, 3, k, y, "q", 0, "rounding_branch");
  nz_lua_read_vector(L, 4, k, y + k, "qd", 0, "rounding_branch");
  int nstate = 2;
  if (!lua_isnil(L, 5)) {
    nz_lua_read_vector(L, 5, k, y + 2 * k, "qdd", 0, "rounding_branch");
    nstate = 3;
  }
  const double *state[3] = { y, y + k, y + 2 * k };
  nz_rounding_branch br;
  unsigned pieces = 0;
  int constraint = -1;
  if (nz_recording_rounding_branch(b.comp, t, state, nstate, tol, &br, &pieces, &constraint) != 1) return 0;
  const nz_gnode *nd = &nz_graph_nodes(nz_recording_graph(b.comp))[br.node];
  luaL_Buffer which;
  luaL_buffinit(L, &which);
  int first = 1;
  for (int p = NZ_PIECE_T; p < NZ_PIECE_COUNT; p++)   /* (F is the T the user wrote: named T) */
    if ((pieces >> p & 1u) || (p == NZ_PIECE_T && (pieces & 1u))) {
      if (!first) luaL_addstring(&which, " and ");
      luaL_addstring(&which, names[p]);
      first = 0;
    }
  luaL_pushresult(&which);
  lua_createtable(L, 0, 9);
  lua_insert(L, -2);
  lua_setfield(L, -2, "piece");
  if (constraint >= 0) {
    lua_pushinteger(L, constraint + 1);
    lua_setfield(L, -2, "constraint");
  }
  lua_pushstring(L, nz_gop_names[nd->op]);
  lua_setfield(L, -2, "op");
  lua_pushinteger(L, nd->fn);
  lua_setfield(L, -2, "fn");
  lua_pushnumber(L, br.value);
  lua_setfield(L, -2, "value");
  lua_pushnumber(L, br.bound);
  lua_setfield(L, -2, "bound");
  lua_pushnumber(L, br.a);
  lua_setfield(L, -2, "a");
  lua_pushnumber(L, br.b);
  lua_setfield(L, -2, "b");
  lua_pushboolean(L, br.rounding);
  lua_setfield(L, -2, "rounding");
  return 1;
}


/* _set_interrupt(flag): request (true) or clear (false) the interrupt, as
 * Ctrl-C does; for tests only (tests/simulate_loop_spec.lua). */
static int lo_set_interrupt(lua_State *L)
{
  if (lua_toboolean(L, 1)) nz_interrupt_request();
  else nz_interrupt_clear();
  return 0;
}

/* Small services of the loop: a monotonic clock, whether a stream is a
 * terminal (the progress bar), and the Ctrl-C flag that C loops poll. */
static int lo_now(lua_State *L)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  lua_pushnumber(L, (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec);
  return 1;
}

static int lo_isatty(lua_State *L)
{
  lua_pushboolean(L, isatty((int)luaL_checkinteger(L, 1)));
  return 1;
}

static int lo_interrupted(lua_State *L)
{
  lua_pushboolean(L, nz_interrupt_requested());
  return 1;
}

static int lo_methods(lua_State *L)
{
  lua_newtable(L);
  for (int i = 0; nz_ode_methods[i]; i++) {
    lua_createtable(L, 0, 2);
    lua_pushstring(L, nz_ode_methods[i]);
    lua_setfield(L, -2, "name");
    lua_pushboolean(L, nz_ode_is_implicit(nz_ode_methods[i]));
    lua_setfield(L, -2, "implicit");
    lua_rawseti(L, -2, i + 1);
  }
  return 1;
}

static const luaL_Reg ode_functions[] = {
  { "ode_new", lo_new }, { "ode_step", lo_step }, { "ode_step_fixed", lo_step_fixed },
  { "ode_accel", lo_accel }, { "ode_rhs", lo_rhs }, { "ode_reset", lo_reset }, { "ode_jacobian", lo_jacobian }, { "ode_stats", lo_stats },
  { "now", lo_now }, { "isatty", lo_isatty }, { "interrupted", lo_interrupted },
  { "ode_methods", lo_methods }, { "ode_run_new", lo_run_new }, { "ode_run", lo_run },
  { "ode_run_state", lo_run_state }, { "ode_run_dense", lo_run_dense }, { "ode_run_native", lo_run_native }, { "ode_run_set_state", lo_run_set_state },
  { "ode_run_jump", lo_run_jump }, { "ode_rounding_branch", lo_rounding_branch },
  { "ode_run_violation", lo_run_violation }, { "ode_events_new", lo_events_new },
  { "ode_event_value", lo_event_value }, { "_set_interrupt", lo_set_interrupt },
  { NULL, NULL }
};

/* Add the functions to the table on top of the stack (core.mech). */
void nz_lua_open_ode(lua_State *L)
{
  nz_lua_gc_metatable(L, NZ_ODE_METATABLE, ode_gc);
  nz_lua_gc_metatable(L, NZ_EVENTS_METATABLE, events_gc);
  nz_lua_gc_metatable(L, NZ_RUN_METATABLE, run_gc);
  luaL_setfuncs(L, ode_functions, 0);
}
