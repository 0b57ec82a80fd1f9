/* lua_variational.c - variational integrators for Lua (see
 * lua_variational.h). */
#include <string.h>
#include <lauxlib.h>
#include "lua/lua_system.h"
#include "lua/lua_util.h"
#include "lua/lua_variational.h"
#include "ode/variational.h"

struct nz_stepper *nz_lua_variational_new(lua_State *L, int cfg)
{
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  const char *name = nz_lua_system_name(L, 1);
  int k = b.sys.k, nc = b.sys.nc;
  nz_variational_config vc;
  memset(&vc, 0, sizeof vc);
  double order = nz_lua_field_number(L, cfg, "order", 2.0);
  if (!(order == 2.0 || order == 4.0 || order == 6.0 || order == 8.0))
    nz_lua_error(L, "system '%s': method 'variational': 'order' must be 2, 4, 6 or 8, got %g", name, order);
  vc.order = (int)order;
  lua_getfield(L, cfg, "verlet");
  vc.verlet = lua_toboolean(L, -1);
  lua_pop(L, 1);
  lua_getfield(L, cfg, "contacts");
  int contacts = !lua_isnil(L, -1);
  lua_pop(L, 1);
  if (contacts)
    nz_lua_error(L, "system '%s': method 'variational' does not take unilateral contacts: take rk8pd or taylor", name);
  int *flags = lua_newuserdatauv(L, 2 * ((size_t)nc + 1) * sizeof(int), 0);
  if (nc > 0) {
    nz_lua_field_ints(L, cfg, "orders", nc, flags);
    nz_lua_field_ints(L, cfg, "linear", nc, flags + nc + 1);
  }
  for (int r = 0; r < nc; r++)
    if (flags[r] != 0)
      nz_lua_error(L, "system '%s': method 'variational' takes holonomic constraints (on q and t), and constraint %d is "
                   "of order %d", name, r + 1, flags[r]);
  nz_accel_options acc = NZ_ACCEL_DEFAULTS;
  acc.newton_tol = nz_lua_field_number(L, cfg, "newton_tol", acc.newton_tol);
  acc.newton_maxit = (int)nz_lua_field_number(L, cfg, "newton_maxit", acc.newton_maxit);
  acc.rcond_min = nz_lua_field_number(L, cfg, "rcond_min", acc.rcond_min);
  vc.setup.k = k;
  vc.setup.nc = nc;
  vc.setup.orders = nc > 0 ? flags : NULL;
  vc.setup.linear = nc > 0 ? flags + nc + 1 : NULL;
  vc.setup.opt = acc;
  vc.nlevels = nz_constraint_levels_max(&b.sys);
  struct nz_stepper *st = nz_variational_new(&vc);
  lua_pop(L, 1);                     /* (the flags: copied) */
  if (!st) luaL_error(L, "not enough memory for the integrator");
  return st;
}

/* What did not converge or was singular, in words. */
static const char *del_text(nz_variational_failure f, const nz_del_report *rep)
{
  if (f == NZ_VARIATIONAL_RATTLE)
    return rep->what == NZ_DEL_SINGULAR ? "the constraint forces of the Stormer-Verlet step (RATTLE) are not determined: "
                                          "the constraints' gradients are dependent there"
                                        : "the constraint forces of the Stormer-Verlet step (RATTLE) did not converge";
  if (rep->velocity)
    return rep->what == NZ_DEL_SINGULAR ? "the velocity from the discrete momentum (the Legendre transform) is not "
                                          "determined: the mass matrix is singular or the constraints' gradients are dependent"
                                        : "the velocity from the discrete momentum (the Legendre transform) did not converge";
  return rep->what == NZ_DEL_SINGULAR ? "the discrete Euler-Lagrange equations have a singular Jacobian: the mass matrix "
                                        "is singular or the constraints' gradients are dependent"
                                      : "the discrete Euler-Lagrange equations did not converge";
}

int nz_lua_variational_raise(lua_State *L, bound_system *b, struct nz_stepper *st, int status)
{
  if (b->ev.interrupted) return nz_lua_raise_interrupt(L);
  int code, k = b->sys.k;
  double t;
  const double *y;
  const nz_del_report *rep;
  const nz_motion_outcome *oc;
  nz_variational_failure f = nz_variational_last_failure(st, &code, &t, &y, &rep, &oc);
  const nz_motion_setup *m = nz_variational_setup(st);
  if (f == NZ_VARIATIONAL_MASS) return nz_lua_raise_singular_mass(L, 1, t, y, y + k, k, &oc->mass);
  if (f == NZ_VARIATIONAL_MOTION && oc->failed == NZ_MOTION_FAILED_MASS)
    return nz_lua_raise_singular_mass(L, 1, t, y, y + k, k, &oc->mass);
  if (f == NZ_VARIATIONAL_MOTION && oc->failed == NZ_MOTION_FAILED_CONSTRAINTS)
    return nz_lua_raise_accel_failure(L, 1, &oc->rep, m->orders, t, y, y + k, k, m->nc);
  if (f == NZ_VARIATIONAL_OK || f == NZ_VARIATIONAL_MOTION || rep->what == NZ_DEL_EVAL)   /* a user function's error */
    return nz_lua_raise_core(L, b, status ? status : NZ_EFUNC, "simulate");
  luaL_Buffer msg;
  luaL_buffinit(L, &msg);
  lua_pushfstring(L, "system '%s': method 'variational': %s", nz_lua_system_name(L, 1), del_text(f, rep));
  luaL_addvalue(&msg);
  nz_lua_add_state(&msg, t, y, y + k, k);
  if (rep->what == NZ_DEL_NEWTON) {
    char num[64];
    nz_lua_fmt_num(num, sizeof num, rep->residual);
    lua_pushfstring(L, " (Newton: %d iterations, the residual %s of its terms)", rep->iterations, num);
    luaL_addvalue(&msg);
  }
  luaL_addstring(&msg, ": the step is too long for the motion there (take a smaller 'step'), or the motion is "
                       "singular there");
  luaL_pushresult(&msg);
  return nz_lua_raise_located(L);
}
