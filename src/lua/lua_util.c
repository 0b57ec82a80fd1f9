/* lua_util.c - what every binding shares (lua_util.h): reading arguments,
 * pushing results, formatting a state into a message, the interrupt object,
 * and the errors raised with the state.  It calls no other binding, so the
 * bindings depend on it and never on each other for these. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "lua/lua_util.h"
#include "mech/constrained.h"

/* Shortest round-trip text of a number, for messages; NaN and infinities
 * the same way on every C library (not "-nan"). */
void nz_lua_fmt_num(char *buf, size_t n, double v)
{
  if (isnan(v) || isinf(v)) {
    snprintf(buf, n, "%s", isnan(v) ? "NaN" : v > 0 ? "inf" : "-inf");
    return;
  }
  snprintf(buf, n, "%.15g", v);
  if (strtod(buf, NULL) != v) snprintf(buf, n, "%.17g", v);
}

/* Is this chunk one of the nz library's own files: embedded as
 * "@lua/nz/FLOOR/NAME.lua" (or the face's "@lua/nz/NAME.lua"), or loaded
 * from a checkout (".../lua/nz/...")?  The same test as
 * nz/base/where.lua's is_library. */
int nz_lua_library_source(const char *source)
{
  if (strncmp(source, "@lua/nz/", 8) == 0) return 1;
  const char *dir = strstr(source, "/lua/nz/");
  if (!dir || source[0] != '@') return 0;
  const char *name = dir + strlen("/lua/nz/");
  size_t n = strlen(name);
  return n > 4 && strcmp(name + n - 4, ".lua") == 0;
}

void nz_lua_user_location(lua_State *L, int level, char *where, size_t n)
{
  lua_Debug ar;
  where[0] = '\0';
  for (; lua_getstack(L, level, &ar); level++) {
    lua_getinfo(L, "Sl", &ar);
    if (ar.currentline <= 0 || nz_lua_library_source(ar.source)) continue;
    snprintf(where, n, "%s:%d:", ar.short_src, ar.currentline);
    return;
  }
}

/* Every error of the bindings about the user's input or state goes out
 * here, so that it starts with the user's file:line as the README promises
 * (a binding is called from the library's Lua files, so luaL_error's level 1
 * would name lua/nz/...; lua_error alone names nothing). */
int nz_lua_raise_located(lua_State *L)
{
  char where[512];
  nz_lua_user_location(L, 0, where, sizeof where);
  size_t n = strlen(where);
  const char *msg = lua_tostring(L, -1);
  if (n > 0 && msg && !(strncmp(msg, where, n) == 0 && msg[n] == ' ')) {
    lua_pushfstring(L, "%s %s", where, msg);
    lua_remove(L, -2);
  }
  return lua_error(L);
}

int nz_lua_error(lua_State *L, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  lua_pushvfstring(L, fmt, ap);
  va_end(ap);
  return nz_lua_raise_located(L);
}

/* The interrupt: one object per Lua state, kept in the registry, that the
 * Ctrl-C hook of nzlua and the bindings raise and that everyone recognises
 * by identity (never by its text: a user's message may say "interrupted!"). */
static const char interrupt_key = 0;

static int interrupt_tostring(lua_State *L)
{
  lua_pushliteral(L, "interrupted!");
  return 1;
}

void nz_lua_push_interrupt(lua_State *L)
{
  if (lua_rawgetp(L, LUA_REGISTRYINDEX, &interrupt_key) != LUA_TNIL) return;
  lua_pop(L, 1);
  lua_newtable(L);
  lua_createtable(L, 0, 3);
  lua_pushcfunction(L, interrupt_tostring);
  lua_setfield(L, -2, "__tostring");
  lua_pushliteral(L, "nz.interrupted");
  lua_setfield(L, -2, "__name");
  lua_pushboolean(L, 0);
  lua_setfield(L, -2, "__metatable");   /* nobody changes what it prints */
  lua_setmetatable(L, -2);
  lua_pushvalue(L, -1);
  lua_rawsetp(L, LUA_REGISTRYINDEX, &interrupt_key);
}

int nz_lua_is_interrupt(lua_State *L, int idx)
{
  idx = lua_absindex(L, idx);
  if (lua_type(L, idx) != LUA_TTABLE) return 0;
  lua_rawgetp(L, LUA_REGISTRYINDEX, &interrupt_key);
  int same = lua_rawequal(L, idx, -1);
  lua_pop(L, 1);
  return same;
}

int nz_lua_raise_interrupt(lua_State *L)
{
  nz_lua_push_interrupt(L);
  return lua_error(L);
}

const char *nz_lua_system_name(lua_State *L, int def)
{
  lua_getfield(L, def, "name");
  const char *name = lua_tostring(L, -1);
  lua_pop(L, 1);     /* the string stays alive in def */
  return name ? name : "unnamed";
}

/* Read k numbers from the table at idx (nil gives zeros when allow_nil). */
void nz_lua_read_vector(lua_State *L, int idx, int k, double *v, const char *what, int allow_nil,
                        const char *fname)
{
  if (allow_nil && lua_isnoneornil(L, idx)) {
    memset(v, 0, (size_t)k * sizeof(double));
    return;
  }
  if (!lua_istable(L, idx))
    nz_lua_error(L, "bad argument to '%s' (%s: a table of %d numbers expected, got %s)", fname, what,
               k, luaL_typename(L, idx));
  if (luaL_len(L, idx) != k)
    nz_lua_error(L, "bad argument to '%s' (%s: %d numbers expected, one per coordinate, got %d)",
               fname, what, k, (int)luaL_len(L, idx));
  for (int i = 0; i < k; i++) {
    lua_geti(L, idx, i + 1);
    int isnum;
    v[i] = lua_tonumberx(L, -1, &isnum);
    lua_pop(L, 1);
    if (!isnum || !isfinite(v[i]))
      nz_lua_error(L, "bad argument to '%s' (%s[%d] must be a finite number)", fname, what, i + 1);
  }
}

int nz_lua_try_vector(lua_State *L, int idx, int k, double *v)
{
  if (lua_type(L, idx) != LUA_TTABLE) return 0;
  if (lua_getmetatable(L, idx)) {
    lua_pop(L, 1);
    return 0;
  }
  if (lua_rawlen(L, idx) != (lua_Unsigned)k) return 0;
  for (int i = 0; i < k; i++) {
    int ok = lua_rawgeti(L, idx, i + 1) == LUA_TNUMBER;
    v[i] = lua_tonumber(L, -1);
    lua_pop(L, 1);
    if (!ok || !isfinite(v[i])) return 0;
  }
  return 1;
}

double nz_lua_field_number(lua_State *L, int idx, const char *name, double dflt)
{
  lua_getfield(L, idx, name);
  double v = luaL_optnumber(L, -1, dflt);
  lua_pop(L, 1);
  return v;
}

void nz_lua_read_ints(lua_State *L, int idx, int n, int *v, const char *what)
{
  luaL_checktype(L, idx, LUA_TTABLE);
  for (int r = 0; r < n; r++) {
    if (lua_geti(L, idx, r + 1) == LUA_TNIL) luaL_error(L, "internal: %s[%d] missing", what, r + 1);
    v[r] = lua_isboolean(L, -1) ? lua_toboolean(L, -1) : (int)luaL_checkinteger(L, -1);
    lua_pop(L, 1);
  }
}

void nz_lua_field_ints(lua_State *L, int idx, const char *name, int n, int *v)
{
  if (n == 0) return;
  lua_getfield(L, idx, name);
  nz_lua_read_ints(L, lua_gettop(L), n, v, name);
  lua_pop(L, 1);
}

void nz_lua_push_vector(lua_State *L, const double *v, int k)
{
  lua_createtable(L, k, 0);
  for (int i = 0; i < k; i++) {
    lua_pushnumber(L, v[i]);
    lua_rawseti(L, -2, i + 1);
  }
}

void nz_lua_push_matrix(lua_State *L, const double *M, int k)
{
  lua_createtable(L, k, 0);
  for (int i = 0; i < k; i++) {
    nz_lua_push_vector(L, M + (size_t)i * (size_t)k, k);
    lua_rawseti(L, -2, i + 1);
  }
}

static void append_numbers(luaL_Buffer *b, const double *v, int k)
{
  char num[40];
  luaL_addchar(b, '{');
  for (int i = 0; i < k; i++) {
    nz_lua_fmt_num(num, sizeof num, v[i]);
    if (i) luaL_addstring(b, ", ");
    luaL_addstring(b, num);
  }
  luaL_addchar(b, '}');
}

void nz_lua_add_state(luaL_Buffer *msg, double t, const double *q, const double *qd, int k)
{
  char num[40];
  nz_lua_fmt_num(num, sizeof num, t);
  luaL_addstring(msg, " at t = ");
  luaL_addstring(msg, num);
  luaL_addstring(msg, ", q = ");
  append_numbers(msg, q, k);
  luaL_addstring(msg, ", qd = ");
  append_numbers(msg, qd, k);
}

void nz_lua_read_tq_qd(lua_State *L, int k, double *t, double *q, double *qd, const char *fname)
{
  *t = luaL_checknumber(L, 2);
  nz_lua_read_vector(L, 3, k, q, "q", 0, fname);
  nz_lua_read_vector(L, 4, k, qd, "qd", 1, fname);
}

/* The error of a singular or indefinite mass matrix, with the state. */
int nz_lua_raise_singular_mass(lua_State *L, int def, double t, const double *q, const double *qd,
                               int k, const nz_solve_info *info)
{
  luaL_Buffer msg;
  char num[64];
  luaL_buffinit(L, &msg);
  lua_pushfstring(L, "system '%s': the mass matrix M = d2T/dqd2 is %s at t = ", nz_lua_system_name(L, def),
                  info->not_spd ? "not positive definite" : "singular or badly conditioned");
  luaL_addvalue(&msg);
  nz_lua_fmt_num(num, sizeof num, t);
  luaL_addstring(&msg, num);
  luaL_addstring(&msg, ", q = ");
  append_numbers(&msg, q, k);
  luaL_addstring(&msg, ", qd = ");
  append_numbers(&msg, qd, k);
  snprintf(num, sizeof num, " (eigenvalues from %.3g to %.3g", info->eig_min, info->eig_max);
  luaL_addstring(&msg, num);
  if (info->eig_min > 0) {
    snprintf(num, sizeof num, ", condition number %.3g", info->eig_max / info->eig_min);
    luaL_addstring(&msg, num);
  } else {
    luaL_addstring(&msg, ", condition number infinite");
  }
  luaL_addstring(&msg, "): check T, or move away from this configuration");
  luaL_pushresult(&msg);
  return nz_lua_raise_located(L);
}

/* What the check after the solve found (NZ_ACCEL_CHECK). */
/* "constraints 1, 2 and 3": the involved ones (how many in *count). */
static void add_involved(luaL_Buffer *msg, const int *involved, int nc, int *count)
{
  char num[40];
  int n = 0, seen = 0;
  for (int r = 0; r < nc; r++) n += involved[r] != 0;
  for (int r = 0; r < nc; r++)
    if (involved[r]) {
      seen++;
      snprintf(num, sizeof num, "%s%d", seen == 1 ? "constraints " : seen == n ? " and " : ", ", r + 1);
      luaL_addstring(msg, num);
    }
  *count = n;
}

static void add_check_failure(luaL_Buffer *msg, const nz_accel_report *rep, const int *orders, int k, int nc)
{
  char num[240];
  int row = rep->check_row;
  if (rep->check_kind == NZ_CHECK_FORWARD)
    snprintf(num, sizeof num, "the accelerations and multipliers of the solve are determined only to a relative "
             "%.2g here (the equilibrated system's reciprocal condition is %.2g, its backward error %.2g; "
             "the check allows %.0e)", rep->check_forward, rep->rcond, rep->check_backward, NZ_ACCEL_FORWARD_TOL);
  else if (row >= k && rep->check_order > 2)
    snprintf(num, sizeof num, "constraint %d, classified of order %d, depends on q^(%d) here (its "
             "terms above order %d are %.3g against %.3g at that order), and accelerations cannot "
             "impose a constraint of order %d", row - k + 1, orders[row - k], rep->check_order,
             orders[row - k], rep->check_violation, rep->check_size, rep->check_order);
  else if (row >= k && rep->check_kind == NZ_CHECK_ORDER)
    snprintf(num, sizeof num, "constraint %d, classified of order %d, depends on the derivatives above it "
             "here (its terms there are %.3g against %.3g at that order), also after classifying it "
             "again at this state", row - k + 1, orders[row - k], rep->check_violation, rep->check_size);
  else
    snprintf(num, sizeof num, "%s %d is violated by %.3g after the solve, a backward error of %.2g of the "
             "equilibrated system (more than the %.0e rounding leaves), also after classifying %s again at "
             "this state", row >= k ? "constraint" : "equation (6.2) for coordinate", row >= k ? row - k + 1 : row + 1,
             rep->check_violation, rep->check_backward, NZ_ACCEL_CHECK_TOL, row >= k ? "it" : "the constraints");
  luaL_addstring(msg, num);
  if (rep->involved && nc > 1 && rep->rank_A > 0 && rep->sigma_ratio < NZ_NEAR_DEPENDENCE) {
    int n;
    luaL_addstring(msg, ": the gradients of ");
    add_involved(msg, rep->involved, nc, &n);
    snprintf(num, sizeof num, " are nearly dependent here (A's smallest singular value is %.2g of its largest): "
             "near a point where they lose rank the motion is not determined", rep->sigma_ratio);
    luaL_addstring(msg, num);
  }
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
  else {
    char how[80];
    if (rep->newton_stop == NZ_NEWTON_NO_PROGRESS && rep->iterations == 0)
      snprintf(how, sizeof how, "stopped at its start: its first step is zero");
    else if (rep->newton_stop == NZ_NEWTON_NO_PROGRESS)
      snprintf(how, sizeof how, "stopped after %d iterations: its step is zero", rep->iterations);
    else if (rep->newton_stop == NZ_NEWTON_VALUE_NOT_FINITE)
      snprintf(how, sizeof how, "stopped after %d iterations on a value that is not finite", rep->iterations);
    else
      snprintf(how, sizeof how, "did not converge in %d iterations", rep->iterations);
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints for (q^(%d), lambda) %s "
             "(residual %.3g, started from %s%s)", p, how, rep->residual,
             rep->from_guess ? "the last root or the guess" : "q^(p) = 0 and least-squares multipliers",
             rep->rcond < 1e-13 ? "; the Jacobian is singular at the last iterate and no step reduces the residual" : "");
  }
  luaL_addstring(msg, num);
}

/* Why Newton's method on (6.2) and the constraints stopped: it ran out of
 * iterations, or (GSL's hybrid method) could not go on from where it stood
 * -- from its start, "did not converge in 0 iterations" said nothing true --
 * and the constraint farthest from 0 there. */
static void add_newton_failure(luaL_Buffer *msg, const nz_accel_report *rep)
{
  char num[480], worst[120] = "", at[64] = "at its start: its first step";
  if (rep->newton_row >= 0)
    snprintf(worst, sizeof worst, "; constraint %d is %.6g there, not 0", rep->newton_row + 1, rep->newton_value);
  if (rep->iterations > 0) snprintf(at, sizeof at, "after %d iterations: its step", rep->iterations);
  switch (rep->newton_stop) {
  case NZ_NEWTON_MAXIT:
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints did not converge in %d "
             "iterations (residual %.3g%s)", rep->iterations, rep->residual, worst);
    break;
  case NZ_NEWTON_STEP_NOT_FINITE:
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints stopped %s was not finite: the "
             "Jacobian in (qdd, lambda) is singular there, as where a constraint's gradient in qdd vanishes "
             "(residual %.3g%s)", at, rep->residual, worst);
    break;
  case NZ_NEWTON_VALUE_NOT_FINITE:
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints stopped after %d iterations: the "
             "constraints or (6.2) were not finite at its next iterate (residual %.3g before%s)", rep->iterations,
             rep->residual, worst);
    break;
  default:
    snprintf(num, sizeof num, "Newton's method on (6.2) and the constraints stopped %s no longer reduced the "
             "residual (%.3g%s), as where there is no real solution near its start or the Jacobian is singular",
             at, rep->residual, worst);
  }
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
    add_check_failure(&msg, &rep, orders, k, nc);
    nz_lua_add_state(&msg, t, q, qd, k);
    luaL_addstring(&msg, rep.check_kind == NZ_CHECK_FORWARD
                   ? ": start away from this configuration, or check the constraints there"
                   : rep.check_order > 2
                   ? ": give a state where it has that order as sample = {...} in nz.system, so that "
                     "it is classified and integrated at its own order, or check the constraint "
                     "where its order changes"
                   : ": check that the constraint is smooth here and consistent with its jet "
                     "(sys:constraints() shows its order and linearity at the sample states)");
  } else if (rep.failure == NZ_ACCEL_NEWTON) {
    add_newton_failure(&msg, &rep);
    nz_lua_add_state(&msg, t, q, qd, k);
    luaL_addstring(&msg, rep.from_guess ? "; started from the guess given"
                                        : "; started from the unconstrained accelerations");
    luaL_addstring(&msg, ": the constraints may have no real solution at this state (check them there); "
                         "if they have one, give Newton another start with sys:accel(t, q, qd, {qdd = ..., "
                         "lambda = ...})");
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
    const char *advice = ": remove a redundant constraint or move away from this configuration";
    for (int r = 0; r < nc; r++)
      if (involved[r]) { ninvolved++; lone = r; }
    if (rep.rank_A < nc && ninvolved == 1) {
      snprintf(num, sizeof num, "constraint %d has a zero gradient dPhi/dq^(m) here (a singular "
               "configuration of the constraint)", lone + 1);
      luaL_addstring(&msg, num);
      advice = ": the motion is not determined there; move away from this configuration, or write the "
               "constraint so that its gradient does not vanish on the motion";
    } else if (rep.rank_A < nc) {
      luaL_addstring(&msg, "dependent constraints: ");
      add_involved(&msg, involved, nc, &ninvolved);
      if (ninvolved == 0)       /* (the diagnosis could not run: out of memory) */
        luaL_addstring(&msg, "which ones could not be found");
      snprintf(num, sizeof num, " (the rank of their gradients A is %d < %d)", rep.rank_A, nc);
      luaL_addstring(&msg, num);
    } else {
      luaL_addstring(&msg, "the mass matrix is singular on the directions the constraints allow");
      advice = ": give every direction the constraints leave free a mass (T positive definite on them), "
               "or move away from this configuration";
    }
    snprintf(num, sizeof num, ": [M A^T; A 0] is singular or badly conditioned (reciprocal condition %.2g)",
             rep.rcond);
    luaL_addstring(&msg, num);
    nz_lua_add_state(&msg, t, q, qd, k);
    luaL_addstring(&msg, advice);
  }
  luaL_pushresult(&msg);
  return nz_lua_raise_located(L);
}


void nz_lua_gc_metatable(lua_State *L, const char *name, lua_CFunction gc)
{
  if (luaL_newmetatable(L, name)) {
    lua_pushcfunction(L, gc);
    lua_setfield(L, -2, "__gc");
  }
  lua_pop(L, 1);
}
