/* lua_constraints.c - constraints for Lua (constrained.h): the primitives
 * that lua/nz/model/constraints.lua classifies with and the constrained
 * accelerations (the error of a failed constrained solve, shared with the
 * integrator, is nz_lua_raise_accel_failure in lua_util.c). */
#include <math.h>
#include <string.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "lua/lua_constraints.h"
#include "lua/lua_system.h"
#include "lua/lua_util.h"

/* ------------------------------------------------------------------ */
/* Constraints                                                          */

/* The head of a binding f(def, r, ...) of nargs arguments (those missing
 * read as nil): bind the system at 1 and return constraint r (argument 2)
 * 0-based. */
static int bind_constraint(lua_State *L, int nargs, bound_system *b)
{
  lua_settop(L, nargs);   /* optional arguments read as nil, scratch above */
  nz_lua_bind_system(L, 1, b);
  lua_Integer r = luaL_checkinteger(L, 2);
  if (r < 1 || r > b->sys.nc)
    return (int)nz_lua_error(L, "system '%s': no constraint %I (it has %d)", nz_lua_system_name(L, 1),
                           (lua_Integer)r, b->sys.nc);
  return (int)r - 1;
}

/* Read the levels constraint r receives: q, qd, qdd, qddd at `at` .. at+3,
 * then the table `higher` at at+4 (or at+5 when skip: the direction sits
 * between) for q^(4), q^(5), ... (nil or missing: zeros).  They go into a
 * new buffer *data of (nlev + extra) vectors of k (extra left for the
 * caller), pointed at by the array returned; both stay on the stack. */
static const double **read_levels(lua_State *L, int at, int k, int nlev, int extra, int higher,
                                  const char *fname, double **data)
{
  static const char *const names[] = { "q", "qd", "qdd", "qddd" };
  *data = lua_newuserdatauv(L, ((size_t)nlev + (size_t)extra) * (size_t)k * sizeof(double), 0);
  const double **levels = lua_newuserdatauv(L, (size_t)nlev * sizeof *levels, 0);
  for (int j = 0; j < nlev; j++) {
    double *v = *data + (size_t)j * (size_t)k;
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
  return levels;
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
  bound_system b;
  int r = bind_constraint(L, 8, &b), k = b.sys.k, S = nz_constraint_levels(&b.sys, r);
  double t = luaL_checknumber(L, 3), value, dphidt, *data;
  const double **levels = read_levels(L, 4, k, S, S, 8, "constraint_partials", &data);
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
  bound_system b;
  int r = bind_constraint(L, 10, &b), k = b.sys.k, S = nz_constraint_levels(&b.sys, r);
  int m = (int)luaL_checkinteger(L, 3);
  luaL_argcheck(L, m >= 0 && m < S, 3, "a slot the constraint receives expected");
  double t = luaL_checknumber(L, 4), c[3], *data;
  const double **levels = read_levels(L, 5, k, S, 1, 10, "constraint_curvature", &data);
  nz_lua_read_vector(L, 9, k, data + (size_t)S * k, "direction", 0, "constraint_curvature");
  int st = nz_constraint_curvature(&b.sys, r, m, t, levels, S, data + (size_t)S * k, c);
  if (st) return nz_lua_raise_core(L, &b, st, "constraint_curvature");
  for (int j = 0; j < 3; j++) lua_pushnumber(L, c[j]);
  return 3;
}

/* constraint_row(def, r, m, t, q, qd, qdd) -> A, value: the acceleration level */
static int ls_constraint_row(lua_State *L)
{
  bound_system b;
  int r = bind_constraint(L, 7, &b), k = b.sys.k;
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

/* constraint_state_gradient(def, r, level, t, q, qd) -> value, dq, dqd:
 * Phi_r^(level) and its gradient in (q, q') (nz_constraint_state_gradient). */
static int ls_constraint_state_gradient(lua_State *L)
{
  bound_system b;
  int r = bind_constraint(L, 6, &b), k = b.sys.k;
  int level = (int)luaL_checkinteger(L, 3);
  luaL_argcheck(L, level == 0 || level == 1, 3, "level 0 or 1 expected");
  double t = luaL_checknumber(L, 4), value;
  double *data = lua_newuserdatauv(L, 5 * (size_t)k * sizeof(double), 0);
  const double *levels[3] = { data, data + k, data + 2 * k };
  nz_lua_read_vector(L, 5, k, data, "q", 0, "constraint_state_gradient");
  nz_lua_read_vector(L, 6, k, data + k, "qd", 1, "constraint_state_gradient");
  memset(data + 2 * k, 0, (size_t)k * sizeof(double));
  int st = nz_constraint_state_gradient(&b.sys, r, level, t, levels, 3, &value, data + 3 * k);
  if (st) return nz_lua_raise_core(L, &b, st, "constraint_state_gradient");
  lua_pushnumber(L, value);
  nz_lua_push_vector(L, data + 3 * k, k);
  nz_lua_push_vector(L, data + 4 * k, k);
  return 3;
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
  nz_lua_read_ints(L, 5, nc, orders, "orders");
  nz_lua_read_ints(L, 6, nc, linear, "linear");
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
  double *A = lua_newuserdatauv(L, ((size_t)nc * (size_t)k + 1) * sizeof(double), 0);
  rep.A = A;
  int st = nz_accel_constrained(&b.sys, orders, linear, t, q, qd, &opt, qdd, lam, &rep);
  if (st == NZ_EFUNC || st == NZ_ENOMEM) return nz_lua_raise_core(L, &b, st, "accel");
  if (st) return nz_lua_raise_accel_failure(L, 1, &rep, orders, t, q, qd, k, nc);
  /* How far the state is from the constraints of order <= 1, relative to
   * the size of their terms (|Phi| + sum |A_i q_i| at position level, |Phi'|
   * + sum |A_i q'_i| at velocity level, as constraints.lua's start check):
   * two rows of each, read as Phi and Phi' (constrained.h), 16 % of the
   * squeezer's sys:accel (callgrind); sys:accel warns with it.  check =
   * false skips it with the check after the solve. */
  double worst = 0.0, worst_value = 0.0;
  int worst_r = -1, worst_level = 0;
  const double *state[3] = { q, qd, qdd };
  double *v = lua_newuserdatauv(L, (2 * (size_t)nc + 1) * sizeof(double), 0);
  if (!opt.skip_check && (st = nz_constraint_state_values(&b.sys, orders, t, state, 3, v)))
    return nz_lua_raise_core(L, &b, st, "accel");
  for (int r = 0; r < nc && !opt.skip_check; r++) {
    if (orders[r] > 1) continue;
    for (int level = orders[r]; level <= 1; level++) {
      double value = v[2 * r + level - orders[r]], size = fabs(value);
      for (int i = 0; i < k; i++) size += fabs(A[(size_t)r * k + i] * (level == 0 ? q[i] : qd[i]));
      double rel = size > 0.0 ? fabs(value) / size : 0.0;
      if (rel > worst) { worst = rel; worst_value = value; worst_r = r; worst_level = level; }
    }
  }
  nz_lua_push_vector(L, qdd, k);
  nz_lua_push_vector(L, lam, nc);
  lua_createtable(L, 0, 8);
  if (worst_r >= 0) {
    lua_createtable(L, 0, 4);
    lua_pushinteger(L, worst_r + 1);
    lua_setfield(L, -2, "constraint");
    lua_pushstring(L, worst_level == 0 ? "position" : "velocity");
    lua_setfield(L, -2, "level");
    lua_pushnumber(L, worst_value);
    lua_setfield(L, -2, "value");
    lua_pushnumber(L, worst);
    lua_setfield(L, -2, "relative");
    lua_setfield(L, -2, "violation");
  }
  if (!opt.skip_check) {                     /* what the check measured */
    lua_pushnumber(L, rep.check_backward);
    lua_setfield(L, -2, "backward_error");
    lua_pushnumber(L, rep.check_forward);
    lua_setfield(L, -2, "error_bound");
  }
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
  bound_system b;
  double t, *buf = nz_lua_bind_tq_qd(L, 4, &b, 0, 1, &t, "force_velocity_jacobian");
  int k = b.sys.k;
  int st = nz_force_velocity_jacobian(&b.sys, t, buf, buf + k, buf + 2 * k);
  if (st) return nz_lua_raise_core(L, &b, st, "force_velocity_jacobian");
  nz_lua_push_matrix(L, buf + 2 * k, k);
  return 1;
}

static const luaL_Reg constraint_functions[] = {
  { "constraint_partials", ls_constraint_partials }, { "constraint_levels", ls_constraint_levels }, { "constraint_curvature", ls_constraint_curvature },
  { "constraint_row", ls_constraint_row }, { "constraint_state_gradient", ls_constraint_state_gradient }, { "accel_constrained", ls_accel_constrained },
  { "force_velocity_jacobian", ls_force_velocity_jacobian }, { NULL, NULL }
};

/* Add the functions to the table on top of the stack (core.mech). */
void nz_lua_open_constraints(lua_State *L)
{
  luaL_setfuncs(L, constraint_functions, 0);
  lua_pushnumber(L, NZ_ACCEL_CHECK_TOL);      /* what the check promises (tests, help) */
  lua_setfield(L, -2, "accel_check_tol");
  lua_pushnumber(L, NZ_ACCEL_FORWARD_TOL);
  lua_setfield(L, -2, "accel_forward_tol");
}
