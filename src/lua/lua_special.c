/* lua_special.c - the few GSL special functions that closed-form references
 * need (the large-amplitude pendulum): nz.special.ellint_K(k) and
 * nz.special.elljac(u, m) -> sn, cn, dn. */
#include <lauxlib.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_sf_ellint.h>
#include <gsl/gsl_sf_elljac.h>
#include "lua/lua_special.h"

static int sp_ellint_K(lua_State *L)
{
  double k = luaL_checknumber(L, 1);
  gsl_sf_result r;
  if (!(k > -1.0 && k < 1.0) || gsl_sf_ellint_Kcomp_e(k, GSL_PREC_DOUBLE, &r) != GSL_SUCCESS)
    return luaL_error(L, "'ellint_K': the modulus k must lie in (-1, 1) (got %f)", k);
  lua_pushnumber(L, r.val);
  return 1;
}

static int sp_elljac(lua_State *L)
{
  double u = luaL_checknumber(L, 1), m = luaL_checknumber(L, 2), sn, cn, dn;
  if (!(m >= 0.0 && m <= 1.0) || gsl_sf_elljac_e(u, m, &sn, &cn, &dn) != GSL_SUCCESS)
    return luaL_error(L, "'elljac': the parameter m = k^2 must lie in [0, 1] (got %f)", m);
  lua_pushnumber(L, sn);
  lua_pushnumber(L, cn);
  lua_pushnumber(L, dn);
  return 3;
}

static const luaL_Reg special_functions[] = {
  { "ellint_K", sp_ellint_K }, { "elljac", sp_elljac }, { NULL, NULL }
};

void nz_lua_open_special(lua_State *L)
{
  luaL_newlib(L, special_functions);
  lua_setfield(L, -2, "special");
}
