/* lua_roots.c - GSL's one-dimensional root finding for Lua: Brent's method
 * on a bracket, for the library's own searches of a parameter value
 * (sys:eigen_sweep locates where a mode changes stability with it).
 *
 * core.mech.root_brent(f, a, b, xtol [, maxit]) -> x, iterations
 *
 * f(a) and f(b) must differ in sign.  f is a Lua function called under
 * lua_pcall from inside GSL's iteration: its error never unwinds through
 * GSL (the solver would leak); it is kept, the iteration stops, the solver
 * is freed, and the error is raised again as it was. */
#include <math.h>
#include <lauxlib.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_roots.h>
#include "lua/lua_roots.h"
#include "lua/lua_util.h"

typedef struct brent_call {
  lua_State *L;
  int failed;                /* 1: f raised an error (on the stack)       */
  int bad;                   /* 1: f returned a non-number or a non-finite one */
  double bad_x;
} brent_call;

static double call_f(double x, void *params)
{
  brent_call *c = params;
  if (c->failed || c->bad) return GSL_NAN;
  lua_State *L = c->L;
  lua_pushvalue(L, 1);
  lua_pushnumber(L, x);
  if (lua_pcall(L, 1, 1, 0) != LUA_OK) { c->failed = 1; return GSL_NAN; }   /* error left on top */
  int isnum;
  double y = lua_tonumberx(L, -1, &isnum);
  lua_pop(L, 1);
  if (!isnum || !isfinite(y)) { c->bad = 1; c->bad_x = x; return GSL_NAN; }
  return y;
}

static int rt_brent(lua_State *L)
{
  luaL_checktype(L, 1, LUA_TFUNCTION);
  double a = luaL_checknumber(L, 2), b = luaL_checknumber(L, 3), xtol = luaL_checknumber(L, 4);
  lua_Integer maxit = luaL_optinteger(L, 5, 200);
  luaL_argcheck(L, a < b, 3, "a bracket a < b expected");
  luaL_argcheck(L, xtol > 0, 4, "a positive tolerance expected");
  lua_settop(L, 1);
  brent_call c = { L, 0, 0, 0.0 };
  gsl_function F = { call_f, &c };
  double fa = call_f(a, &c), fb = call_f(b, &c);
  if (c.failed) return lua_error(L);
  if (c.bad) return nz_lua_error(L, "'root_brent': f(%g) is not a finite number", c.bad_x);
  if (fa * fb > 0) return nz_lua_error(L, "'root_brent': f(%g) = %g and f(%g) = %g have the same sign", a, fa, b, fb);
  if (fa == 0) { lua_pushnumber(L, a); lua_pushinteger(L, 0); return 2; }
  if (fb == 0) { lua_pushnumber(L, b); lua_pushinteger(L, 0); return 2; }
  gsl_root_fsolver *s = gsl_root_fsolver_alloc(gsl_root_fsolver_brent);
  if (!s) return nz_lua_error(L, "'root_brent': not enough memory");
  int st = gsl_root_fsolver_set(s, &F, a, b);
  lua_Integer it = 0;
  while (st == GSL_SUCCESS && it < maxit) {
    it++;
    st = gsl_root_fsolver_iterate(s);
    if (st != GSL_SUCCESS) break;
    st = gsl_root_test_interval(gsl_root_fsolver_x_lower(s), gsl_root_fsolver_x_upper(s), xtol, 0.0);
    if (st == GSL_SUCCESS) break;
    if (st == GSL_CONTINUE) st = GSL_SUCCESS;
    else break;
  }
  double x = gsl_root_fsolver_root(s), lo = gsl_root_fsolver_x_lower(s), hi = gsl_root_fsolver_x_upper(s);
  gsl_root_fsolver_free(s);
  if (c.failed) return lua_error(L);
  if (c.bad) return nz_lua_error(L, "'root_brent': f(%g) is not a finite number", c.bad_x);
  if (st != GSL_SUCCESS || hi - lo > xtol)
    return nz_lua_error(L, "'root_brent': no convergence to %g in %d iterations (bracket [%.17g, %.17g]; %s)", xtol,
                      (int)it, lo, hi, gsl_strerror(st));
  lua_pushnumber(L, x);
  lua_pushinteger(L, it);
  return 2;
}

static const luaL_Reg root_functions[] = { { "root_brent", rt_brent }, { NULL, NULL } };

void nz_lua_open_roots(lua_State *L) { luaL_setfuncs(L, root_functions, 0); }
