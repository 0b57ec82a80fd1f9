/* lua_constraints.c - constraints for Lua (constrained.h): the primitives
 * that lua/nz/constraints.lua classifies with, the constrained accelerations,
 * and the errors of a failed constrained solve (shared with the integrator). */
#include <math.h>
#include <string.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "lua/lua_system.h"

/* ------------------------------------------------------------------ */
/* Constraints                                                          */

static int check_constraint(lua_State *L, bound_system *b, int idx)
{
  lua_Integer r = luaL_checkinteger(L, idx);
  if (r < 1 || r > b->sys.nc)
    return (int)luaL_error(L, "system '%s': no constraint %I (it has %d)", nz_lua_system_name(L, 1),
                           (lua_Integer)r, b->sys.nc);
  return (int)r - 1;
}

/* Read the levels constraint r receives: q, qd, qdd, qddd at `at` .. at+3,
 * then the table `higher` at at+4 (or at+5 when skip: the direction sits
 * between) for q^(4), q^(5), ... (nil or missing: zeros).  data holds
 * nlev * k doubles. */
static void read_levels(lua_State *L, int at, int k, int nlev, double *data, const double **levels,
                        int higher, const char *fname)
{
  static const char *const names[] = { "q", "qd", "qdd", "qddd" };
  for (int j = 0; j < nlev; j++) {
    double *v = data + (size_t)j * (size_t)k;
    levels[j] = v;
    if (j < NZ_CONSTRAINT_SLOTS) {
      nz_lua_read_vector(L, at + j, k, v, names[j], j > 0, fname);
      continue;
    }
    if (lua_istable(L, higher)) lua_geti(L, higher, j - NZ_CONSTRAINT_SLOTS + 1);
    else lua_pushnil(L);
    nz_lua_read_vector(L, lua_gettop(L), k, v, "higher derivative", 1, fname);
    lua_pop(L, 1);
  }
}

/* constraint_levels(list) -> an array of ints for def.constraint_levels:
 * the derivative slots each constraint receives (nz_system.levels). */
static int ls_constraint_levels(lua_State *L)
{
  luaL_checktype(L, 1, LUA_TTABLE);
  int n = (int)luaL_len(L, 1);
  int *v = lua_newuserdatauv(L, ((size_t)n + 1) * sizeof(int), 0);
  v[0] = n;
  for (int r = 0; r < n; r++) {
    lua_geti(L, 1, r + 1);
    lua_Integer x = luaL_checkinteger(L, -1);
    lua_pop(L, 1);
    luaL_argcheck(L, x >= 1 && x <= NZ_MAX_LEVELS, 1, "slot counts between 1 and the largest level expected");
    v[r + 1] = (int)x;
  }
  return 1;
}

/* constraint_partials(def, r, t, q, qd, qdd, qddd, higher) -> value,
 * {dq, dqd, dqdd, dqddd, ...} (one per slot the constraint receives), dphidt */
static int ls_constraint_partials(lua_State *L)
{
  lua_settop(L, 8);   /* optional arguments read as nil, scratch above */
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int r = check_constraint(L, &b, 2), k = b.sys.k, S = nz_constraint_levels(&b.sys, r);
  double t = luaL_checknumber(L, 3), value, dphidt;
  double *data = lua_newuserdatauv(L, 2 * (size_t)S * (size_t)k * sizeof(double), 0);
  const double **levels = lua_newuserdatauv(L, (size_t)S * sizeof *levels, 0);
  read_levels(L, 4, k, S, data, levels, 8, "constraint_partials");
  double *dphi = data + (size_t)S * k;
  int st = nz_constraint_partials(&b.sys, r, t, levels, S, &value, dphi, &dphidt);
  if (st) return nz_lua_raise_core(L, &b, st, "constraint_partials");
  lua_pushnumber(L, value);
  lua_createtable(L, S, 0);
  for (int j = 0; j < S; j++) {
    nz_lua_push_vector(L, dphi + (size_t)j * k, k);
    lua_rawseti(L, -2, j + 1);
  }
  lua_pushnumber(L, dphidt);
  return 3;
}

/* constraint_curvature(def, r, m, t, q, qd, qdd, qddd, v, higher) -> c0, c1, c2 */
static int ls_constraint_curvature(lua_State *L)
{
  lua_settop(L, 10);   /* optional arguments read as nil, scratch above */
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int r = check_constraint(L, &b, 2), k = b.sys.k, S = nz_constraint_levels(&b.sys, r);
  int m = (int)luaL_checkinteger(L, 3);
  luaL_argcheck(L, m >= 0 && m < S, 3, "a slot the constraint receives expected");
  double t = luaL_checknumber(L, 4), c[3];
  double *data = lua_newuserdatauv(L, ((size_t)S + 1) * (size_t)k * sizeof(double), 0);
  const double **levels = lua_newuserdatauv(L, (size_t)S * sizeof *levels, 0);
  read_levels(L, 5, k, S, data, levels, 10, "constraint_curvature");
  nz_lua_read_vector(L, 9, k, data + (size_t)S * k, "direction", 0, "constraint_curvature");
  int st = nz_constraint_curvature(&b.sys, r, m, t, levels, S, data + (size_t)S * k, c);
  if (st) return nz_lua_raise_core(L, &b, st, "constraint_curvature");
  for (int j = 0; j < 3; j++) lua_pushnumber(L, c[j]);
  return 3;
}

/* constraint_row(def, r, m, t, q, qd, qdd) -> A, value: the acceleration level */
static int ls_constraint_row(lua_State *L)
{
  lua_settop(L, 7);   /* optional arguments read as nil, scratch above */
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int r = check_constraint(L, &b, 2), k = b.sys.k;
  int m = (int)luaL_checkinteger(L, 3);
  luaL_argcheck(L, m >= 0 && m <= 2, 3, "order between 0 and 2 expected");
  double t = luaL_checknumber(L, 4), value;
  double *data = lua_newuserdatauv(L, 4 * (size_t)k * sizeof(double), 0);
  const double *levels[3] = { data, data + k, data + 2 * k };
  nz_lua_read_vector(L, 5, k, data, "q", 0, "constraint_row");
  nz_lua_read_vector(L, 6, k, data + k, "qd", 1, "constraint_row");
  nz_lua_read_vector(L, 7, k, data + 2 * k, "qdd", 1, "constraint_row");
  int st = nz_constraint_row(&b.sys, r, m, t, levels, 3, data + 3 * k, &value);
  if (st) return nz_lua_raise_core(L, &b, st, "constraint_row");
  nz_lua_push_vector(L, data + 3 * k, k);
  lua_pushnumber(L, value);
  return 2;
}

static void read_flags(lua_State *L, int idx, int n, int *v, const char *what)
{
  luaL_checktype(L, idx, LUA_TTABLE);
  for (int r = 0; r < n; r++) {
    lua_geti(L, idx, r + 1);
    v[r] = lua_isboolean(L, -1) ? lua_toboolean(L, -1) : (int)luaL_optinteger(L, -1, -1);
    lua_pop(L, 1);
    if (v[r] < 0) luaL_error(L, "internal: %s[%d] missing", what, r + 1);
  }
}


/* What the check after the solve found (NZ_ACCEL_CHECK). */
static void add_check_failure(luaL_Buffer *msg, const nz_accel_report *rep, const int *orders, int k)
{
  char num[240];
  int row = rep->check_row;
  if (row >= k && rep->check_order > 2)
    snprintf(num, sizeof num, "constraint %d, classified of order %d, depends on q^(%d) here (its "
             "terms above order %d are %.3g against %.3g at that order), and accelerations cannot "
             "impose a constraint of order %d", row - k + 1, orders[row - k], rep->check_order,
             orders[row - k], rep->check_violation, rep->check_size, rep->check_order);
  else if (row >= k)
    snprintf(num, sizeof num, "constraint %d is violated by %.3g (its terms are of size %.3g) after "
             "the solve, also after classifying it again at this state", row - k + 1,
             rep->check_violation, rep->check_size);
  else
    snprintf(num, sizeof num, "equation (6.2) for coordinate %d is violated by %.3g (its terms are "
             "of size %.3g) after the solve, also after classifying the constraints again at this "
             "state", row + 1, rep->check_violation, rep->check_size);
  luaL_addstring(msg, num);
}

/* A constraint of order p nonlinear in q^(p) (constrained_series.h): why
 * the solve for (q^(p), lambda) failed. */
static void add_top_failure(luaL_Buffer *msg, const nz_accel_report *rep, const int *orders, int nc)
{
  char num[400];
  int p = 0;
  for (int r = 0; r < nc; r++)
    if (orders[r] > p) p = orders[r];
  if (rep->failure == NZ_ACCEL_TOP_SINGULAR)
    snprintf(num, sizeof num, "a constraint nonlinear in q^(%d) fixes q^(%d) only through lambda "
             "d2Phi/dq^(%d)2 in (6.2): the Jacobian of (6.2) and the constraints in (q^(%d), lambda) is "
             "singular (reciprocal condition %.2g), as where the multipliers vanish", p, p, p, p, rep->rcond);
  else
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints for (q^(%d), lambda) did not "
             "converge in %d iterations (residual %.3g, started from %s%s)", p, rep->iterations, rep->residual,
             rep->from_guess ? "the last root or the guess" : "q^(p) = 0 and least-squares multipliers",
             rep->rcond < 1e-13 ? "; the Jacobian is singular at the last iterate and no step reduces the residual" : "");
  luaL_addstring(msg, num);
}

/* The error of a failed constrained solve: why, where, and what to do. */
int nz_lua_raise_accel_failure(lua_State *L, int def, const nz_accel_report *rep_, const int *orders,
                               double t, const double *q, const double *qd, int k, int nc)
{
  nz_accel_report rep = *rep_;
  const int *involved = rep.involved;
  luaL_Buffer msg;
  char num[160];
  luaL_buffinit(L, &msg);
  lua_pushfstring(L, "system '%s': ", nz_lua_system_name(L, def));
  luaL_addvalue(&msg);
  if (rep.failure == NZ_ACCEL_ORDER) {
    for (int r = 0; r < nc; r++)
      if (orders[r] > 2) {
        snprintf(num, sizeof num, "constraint %d is of order %d", r + 1, orders[r]);
        luaL_addstring(&msg, num);
        break;
      }
    luaL_addstring(&msg, ": under it q'' is part of the state, not a function of (t, q, qd), so "
                         "accelerations come from the state: integrate with sys:simulate{..., qdd0 = ...} "
                         "(residuals, classification and sys:project work)");
  } else if (rep.failure == NZ_ACCEL_CHECK) {
    add_check_failure(&msg, &rep, orders, k);
    nz_lua_add_state(&msg, t, q, qd, k);
    luaL_addstring(&msg, rep.check_order > 2
                   ? ": give a state where it has that order as sample = {...} in nz.system, so that "
                     "it is classified and integrated at its own order, or check the constraint "
                     "where its order changes"
                   : ": check that the constraint is smooth here and consistent with its jet "
                     "(sys:constraints() shows its order and linearity at the sample states)");
  } else if (rep.failure == NZ_ACCEL_NEWTON) {
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints did not converge in %d "
             "iterations (residual %.3g)", rep.iterations, rep.residual);
    luaL_addstring(&msg, num);
    nz_lua_add_state(&msg, t, q, qd, k);
    luaL_addstring(&msg, rep.from_guess ? "; started from the guess given"
                                        : "; started from the unconstrained accelerations");
    luaL_addstring(&msg, ": give another start with sys:accel(t, q, qd, {qdd = ..., lambda = ...}), "
                         "or check that the constraints have a real solution here");
  } else if (rep.failure == NZ_ACCEL_TOP_SINGULAR || rep.failure == NZ_ACCEL_TOP_NEWTON) {
    add_top_failure(&msg, &rep, orders, nc);
    nz_lua_add_state(&msg, t, q, qd, k);
    /* The level state: q'' follows qd in y (ode.c). */
    snprintf(num, sizeof num, ", qdd = {");
    luaL_addstring(&msg, num);
    for (int i = 0; i < k; i++) {
      snprintf(num, sizeof num, "%s%.6g", i ? ", " : "", qd[k + i]);
      luaL_addstring(&msg, num);
    }
    luaL_addstring(&msg, "}");
    if (rep.failure == NZ_ACCEL_TOP_SINGULAR)
      luaL_addstring(&msg, ": the motion is not determined there; start where the multipliers are not zero, "
                           "or reformulate the constraint");
    else {
      int p = 0;
      for (int r = 0; r < nc; r++) p = orders[r] > p ? orders[r] : p;
      snprintf(num, sizeof num, ": give Newton a start with simulate{..., guess = {lambda = ..., q%dd = ...}}, "
               "or check that the constraints have a real solution here", p);
      luaL_addstring(&msg, num);
    }
  } else {
    int ninvolved = 0, lone = 0;
    for (int r = 0; r < nc; r++)
      if (involved[r]) { ninvolved++; lone = r; }
    if (rep.rank_A < nc && ninvolved == 1) {
      snprintf(num, sizeof num, "constraint %d has a zero gradient dPhi/dq^(m) here (a singular "
               "configuration of the constraint)", lone + 1);
      luaL_addstring(&msg, num);
    } else if (rep.rank_A < nc) {
      luaL_addstring(&msg, "dependent constraints: ");
      int first = 1;
      for (int r = 0; r < nc; r++)
        if (involved[r]) {
          snprintf(num, sizeof num, "%s%d", first ? "constraints " : " and ", r + 1);
          luaL_addstring(&msg, num);
          first = 0;
        }
      snprintf(num, sizeof num, " (the rank of their gradients A is %d < %d)", rep.rank_A, nc);
      luaL_addstring(&msg, num);
    } else {
      luaL_addstring(&msg, "the mass matrix is singular on the directions the constraints allow");
    }
    snprintf(num, sizeof num, ": [M A^T; A 0] is singular or badly conditioned (reciprocal condition %.2g)",
             rep.rcond);
    luaL_addstring(&msg, num);
    nz_lua_add_state(&msg, t, q, qd, k);
    luaL_addstring(&msg, ": remove a redundant constraint or move away from this configuration");
  }
  luaL_pushresult(&msg);
  return lua_error(L);
}

/* accel_constrained(def, t, q, qd, orders, linear, opts) -> qdd, lambda, report */
static int ls_accel_constrained(lua_State *L)
{
  lua_settop(L, 7);   /* optional arguments read as nil, scratch above */
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int k = b.sys.k, nc = b.sys.nc;
  double t = luaL_checknumber(L, 2);
  double *data = lua_newuserdatauv(L, (5 * (size_t)k + 2 * (size_t)nc) * sizeof(double), 0);
  double *q = data, *qd = q + k, *qdd = qd + k, *gq = qdd + k, *lam = gq + k, *gl = lam + nc;
  nz_lua_read_vector(L, 3, k, q, "q", 0, "accel");
  nz_lua_read_vector(L, 4, k, qd, "qd", 1, "accel");
  int *ints = lua_newuserdatauv(L, 3 * (size_t)(nc + 1) * sizeof(int), 0);
  int *orders = ints, *linear = ints + nc + 1, *involved = ints + 2 * (nc + 1);
  read_flags(L, 5, nc, orders, "orders");
  read_flags(L, 6, nc, linear, "linear");
  memset(involved, 0, (size_t)(nc + 1) * sizeof(int));
  nz_accel_options opt = NZ_ACCEL_DEFAULTS;
  if (lua_istable(L, 7)) {
    if (lua_getfield(L, 7, "tol") == LUA_TNUMBER) opt.newton_tol = lua_tonumber(L, -1);
    if (lua_getfield(L, 7, "maxit") == LUA_TNUMBER) opt.newton_maxit = (int)lua_tointeger(L, -1);
    if (lua_getfield(L, 7, "rcond_min") == LUA_TNUMBER) opt.rcond_min = lua_tonumber(L, -1);
    if (lua_getfield(L, 7, "check") == LUA_TBOOLEAN) opt.skip_check = !lua_toboolean(L, -1);
    if (lua_getfield(L, 7, "qdd") == LUA_TTABLE) {
      nz_lua_read_vector(L, lua_gettop(L), k, gq, "guess qdd", 0, "accel");
      opt.guess_qdd = gq;
    }
    if (lua_getfield(L, 7, "lambda") == LUA_TTABLE) {
      luaL_argcheck(L, luaL_len(L, -1) == nc, 7, "lambda: one multiplier per constraint expected");
      for (int r = 0; r < nc; r++) {
        lua_geti(L, -1, r + 1);
        gl[r] = luaL_checknumber(L, -1);
        lua_pop(L, 1);
      }
      opt.guess_lambda = gl;
    }
    lua_pop(L, 6);
  }
  nz_accel_report rep;
  memset(&rep, 0, sizeof rep);
  rep.involved = involved;
  int st = nz_accel_constrained(&b.sys, orders, linear, t, q, qd, &opt, qdd, lam, &rep);
  if (st == NZ_EFUNC || st == NZ_ENOMEM) return nz_lua_raise_core(L, &b, st, "accel");
  if (st) return nz_lua_raise_accel_failure(L, 1, &rep, orders, t, q, qd, k, nc);
  nz_lua_push_vector(L, qdd, k);
  nz_lua_push_vector(L, lam, nc);
  lua_createtable(L, 0, 5);
  lua_pushinteger(L, rep.reclassified);
  lua_setfield(L, -2, "reclassified");
  lua_pushinteger(L, rep.iterations);
  lua_setfield(L, -2, "iterations");
  lua_pushnumber(L, rep.residual);
  lua_setfield(L, -2, "residual");
  lua_pushnumber(L, rep.rcond);
  lua_setfield(L, -2, "rcond");
  lua_pushstring(L, rep.from_guess ? "guess" : "unconstrained");
  lua_setfield(L, -2, "start");
  return 3;
}

/* force_velocity_jacobian(def, t, q, qd) -> dQ/dqd */
static int ls_force_velocity_jacobian(lua_State *L)
{
  lua_settop(L, 4);   /* optional arguments read as nil, scratch above */
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int k = b.sys.k;
  double t, *buf = lua_newuserdatauv(L, (2 * (size_t)k + (size_t)k * k) * sizeof(double), 0);
  nz_lua_read_tq_qd(L, k, &t, buf, buf + k, "force_velocity_jacobian");
  int st = nz_force_velocity_jacobian(&b.sys, t, buf, buf + k, buf + 2 * k);
  if (st) return nz_lua_raise_core(L, &b, st, "force_velocity_jacobian");
  nz_lua_push_matrix(L, buf + 2 * k, k);
  return 1;
}

static const luaL_Reg constraint_functions[] = {
  { "constraint_partials", ls_constraint_partials }, { "constraint_levels", ls_constraint_levels }, { "constraint_curvature", ls_constraint_curvature },
  { "constraint_row", ls_constraint_row }, { "accel_constrained", ls_accel_constrained },
  { "force_velocity_jacobian", ls_force_velocity_jacobian }, { NULL, NULL }
};

/* Add the functions to the table on top of the stack (core.mech). */
void nz_lua_open_constraints(lua_State *L)
{
  luaL_setfuncs(L, constraint_functions, 0);
  nz_lua_open_series(L);
  lua_pushnumber(L, NZ_ACCEL_CHECK_TOL);      /* what the check promises (tests, help) */
  lua_setfield(L, -2, "accel_check_tol");
}
