/* lua_series.c - the motion at level p >= 3 (constrained_series.h) for Lua:
 * the start state's multipliers and its check, its completion, the closure
 * test and the equations of one level.  lua/nz/model/constraints.lua and
 * lua/nz/motion/simulate.lua call these; the stepping itself goes through the
 * integrator (lua_ode.c, cfg.level). */
#include <string.h>
#include <lauxlib.h>
#include "mech/constrained_series.h"
#include "lua/lua_series.h"
#include "lua/lua_system.h"
#include "lua/lua_util.h"

/* The classification's orders, one per constraint, from the table at idx. */
static int *read_orders(lua_State *L, int idx, int nc)
{
  luaL_checktype(L, idx, LUA_TTABLE);
  int *o = lua_newuserdatauv(L, ((size_t)nc + 1) * sizeof(int), 0);
  for (int r = 0; r < nc; r++) {
    lua_geti(L, idx, r + 1);
    o[r] = (int)luaL_checkinteger(L, -1);
    lua_pop(L, 1);
  }
  return o;
}

static int check_level(lua_State *L, int idx, int lo)
{
  lua_Integer p = luaL_checkinteger(L, idx);
  luaL_argcheck(L, p >= lo && p + 3 <= NZ_MAX_LEVELS, idx, "level out of range");
  return (int)p;
}

/* n levels q, qd, ... from the list at idx into fresh storage (missing: 0). */
static double **read_level_list(lua_State *L, int idx, int k, int n, const char *fname)
{
  luaL_checktype(L, idx, LUA_TTABLE);
  double *data = lua_newuserdatauv(L, (size_t)n * (size_t)k * sizeof(double), 0);
  double **lv = lua_newuserdatauv(L, (size_t)n * sizeof *lv, 0);
  for (int j = 0; j < n; j++) {
    lv[j] = data + (size_t)j * k;
    lua_geti(L, idx, j + 1);
    nz_lua_read_vector(L, lua_gettop(L), k, lv[j], "derivative level", 1, fname);
    lua_pop(L, 1);
  }
  return lv;
}

/* The arguments every function here starts with, (def, orders, level, t,
 * levels): the system bound for this call, the classification's orders, the
 * level (at least lo) and nlevels = level + extra levels q, qd, ... */
typedef struct series_call {
  bound_system b;
  int k, nc, *orders, level;
  double t;
  double **lv;
} series_call;

static void read_series_call(lua_State *L, series_call *c, int lo, int extra, const char *fname)
{
  nz_lua_bind_system(L, 1, &c->b);
  c->k = c->b.sys.k;
  c->nc = c->b.sys.nc;
  c->orders = read_orders(L, 2, c->nc);
  c->level = check_level(L, 3, lo);
  c->t = luaL_checknumber(L, 4);
  c->lv = read_level_list(L, 5, c->k, c->level + extra, fname);
}

/* Up to n lists of nc multipliers from the optional list at idx into lam
 * (what is missing stays as the caller set it). */
static void read_lambda_list(lua_State *L, int idx, double *lam, int n, int nc, const char *fname)
{
  for (int j = 0; j < n && lua_istable(L, idx); j++) {
    lua_geti(L, idx, j + 1);
    if (lua_istable(L, -1)) nz_lua_read_vector(L, lua_gettop(L), nc, lam + (size_t)j * nc, "lambda", 1, fname);
    lua_pop(L, 1);
  }
}

/* Push n tables of m numbers from v (row-major) as a list. */
static void push_rows(lua_State *L, const double *v, int n, int m)
{
  lua_createtable(L, n, 0);
  for (int j = 0; j < n; j++) {
    nz_lua_push_vector(L, v + (size_t)j * m, m);
    lua_rawseti(L, -2, j + 1);
  }
}

/* series_level(def, orders, l, t, levels, lambdas) -> res (k + nc), A rows */
static int ls_series_level(lua_State *L)
{
  lua_settop(L, 6);
  series_call c;
  read_series_call(L, &c, 0, 1, "series_level");
  int k = c.k, nc = c.nc, l = c.level;
  double *lam = lua_newuserdatauv(L, ((size_t)(l + 1) * nc + (size_t)k + (size_t)nc + (size_t)nc * k) * sizeof(double), 0);
  double *res = lam + (size_t)(l + 1) * nc, *A = res + k + nc;
  memset(lam, 0, (size_t)(l + 1) * nc * sizeof(double));
  read_lambda_list(L, 6, lam, l - 1, nc, "series_level");      /* lambda .. lambda^(l-2) */
  int st = nz_series_level(&c.b.sys, c.orders, l, c.t, (const double *const *)c.lv, lam, res, A, NULL);
  if (st) return nz_lua_raise_core(L, &c.b, st, "series_level");
  nz_lua_push_vector(L, res, k + nc);
  push_rows(L, A, nc, k);
  return 2;
}

/* series_initial(def, orders, p, t, levels) -> lambdas (p - 2 lists),
 * {value, level, row} of the worst violation */
static int ls_series_initial(lua_State *L)
{
  lua_settop(L, 5);
  series_call c;
  read_series_call(L, &c, 3, 0, "series_initial");
  int nc = c.nc, p = c.level;
  double *lam = lua_newuserdatauv(L, ((size_t)(p - 2) * nc + 1) * sizeof(double), 0);
  nz_series_violation v;
  int st = nz_series_initial(&c.b.sys, c.orders, p, c.t, (const double *const *)c.lv, lam, &v);
  if (st) return nz_lua_raise_core(L, &c.b, st, "simulate");
  push_rows(L, lam, p - 2, nc);
  lua_createtable(L, 0, 3);
  lua_pushnumber(L, v.value);
  lua_setfield(L, -2, "value");
  lua_pushinteger(L, v.level);
  lua_setfield(L, -2, "level");
  lua_pushinteger(L, v.row + 1);
  lua_setfield(L, -2, "row");
  return 2;
}

/* series_project(def, orders, p, t, levels, tol, maxit[, lambdas]) -> levels
 * (p lists), lambdas (p - 2 lists), iterations; nil and the iterations when
 * it fails.  lambdas: the multipliers chosen (a list per level, or nil
 * where they are free; free with zeros as the start when absent). */
static int ls_series_project(lua_State *L)
{
  lua_settop(L, 8);
  series_call c;
  read_series_call(L, &c, 3, 0, "project");
  int k = c.k, nc = c.nc, p = c.level;
  double tol = luaL_checknumber(L, 6);
  int maxit = (int)luaL_checkinteger(L, 7), its = 0;
  double *lam = lua_newuserdatauv(L, ((size_t)(p - 2) * nc + 1) * sizeof(double), 0);
  int *chosen = lua_newuserdatauv(L, (size_t)p * sizeof(int), 0);
  memset(lam, 0, ((size_t)(p - 2) * nc + 1) * sizeof(double));
  read_lambda_list(L, 8, lam, p - 2, nc, "project");
  for (int j = 0; j < p - 2; j++) {
    chosen[j] = lua_istable(L, 8) && lua_geti(L, 8, j + 1) == LUA_TTABLE;
    if (lua_istable(L, 8)) lua_pop(L, 1);
  }
  int st = nz_series_project(&c.b.sys, c.orders, p, c.t, c.lv, lam, chosen, tol, maxit, &its);
  if (st == NZ_EARG) {
    lua_pushnil(L);
    lua_pushinteger(L, its);
    return 2;
  }
  if (st) return nz_lua_raise_core(L, &c.b, st, "project");
  lua_createtable(L, p, 0);
  for (int j = 0; j < p; j++) {
    nz_lua_push_vector(L, c.lv[j], k);
    lua_rawseti(L, -2, j + 1);
  }
  push_rows(L, lam, p - 2, nc);
  lua_pushinteger(L, its);
  return 3;
}

/* series_closure(def, orders, p, t, levels) -> the first constraint whose
 * gradient needs derivatives above q^(p) at this state, or nil */
static int ls_series_closure(lua_State *L)
{
  lua_settop(L, 5);
  series_call c;
  read_series_call(L, &c, 3, 1, "simulate");
  int bad, p = c.level;
  int st = nz_series_closure(&c.b.sys, c.orders, p, c.t, (const double *const *)c.lv, &bad);
  if (st) return nz_lua_raise_core(L, &c.b, st, "simulate");
  if (bad < 0) lua_pushnil(L);
  else lua_pushinteger(L, bad + 1);
  return 1;
}

static const luaL_Reg series_functions[] = {
  { "series_level", ls_series_level }, { "series_initial", ls_series_initial },
  { "series_project", ls_series_project }, { "series_closure", ls_series_closure }, { NULL, NULL }
};

void nz_lua_open_series(lua_State *L) { luaL_setfuncs(L, series_functions, 0); }
