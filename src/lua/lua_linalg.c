/* lua_linalg.c - the dense linear algebra Lua needs (linalg.h, GSL): least
 * squares of minimum norm (projection, Tsenov's elimination) and singular
 * values (nz.check's rank test); eigenvalues and eigenvectors of a real
 * matrix (sys:linearize). */
#include <lauxlib.h>
#include "core/linalg.h"
#include "lua/lua_linalg.h"
#include "lua/lua_util.h"

/* Read the matrix at idx (a list of rows of numbers) into a new userdata
 * with `extra` more doubles after it; sets *m, *n. */
static double *read_matrix(lua_State *L, int idx, int *m, int *n, size_t extra, const char *fname)
{
  luaL_checktype(L, idx, LUA_TTABLE);
  *m = (int)luaL_len(L, idx);
  luaL_argcheck(L, *m >= 1, idx, "at least one row expected");
  lua_geti(L, idx, 1);
  *n = (int)luaL_len(L, -1);
  lua_pop(L, 1);
  luaL_argcheck(L, *n >= 1, idx, "rows of at least one number expected");
  double *A = lua_newuserdatauv(L, ((size_t)*m * (size_t)*n + extra) * sizeof(double), 0);
  for (int i = 0; i < *m; i++) {
    lua_geti(L, idx, i + 1);
    nz_lua_read_vector(L, lua_gettop(L), *n, A + (size_t)i * (size_t)*n, "row", 0, fname);
    lua_pop(L, 1);
  }
  return A;
}

/* lstsq(A, b) -> x of minimum norm minimizing |A x - b| (A a list of rows). */
static int ls_lstsq(lua_State *L)
{
  lua_settop(L, 2);
  int m, n;
  double *A = read_matrix(L, 1, &m, &n, 0, "lstsq");
  double *bb = lua_newuserdatauv(L, ((size_t)m + (size_t)n) * sizeof(double), 0), *x = bb + m;
  nz_lua_read_vector(L, 2, m, bb, "b", 0, "lstsq");
  if (nz_lstsq(m, n, A, bb, x)) return luaL_error(L, "'lstsq': not enough memory");
  nz_lua_push_vector(L, x, n);
  return 1;
}

/* singular_values(A) -> the singular values of A (a list of rows), largest first. */
static int ls_singular_values(lua_State *L)
{
  int m, n;
  double *A = read_matrix(L, 1, &m, &n, 0, "singular_values");
  nz_svd d;
  if (nz_svd_of(&d, m, n, A, m < n)) return luaL_error(L, "'singular_values': not enough memory");
  int c = m < n ? m : n;
  lua_createtable(L, c, 0);
  for (int i = 0; i < c; i++) {
    lua_pushnumber(L, gsl_vector_get(d.S, (size_t)i));
    lua_rawseti(L, -2, i + 1);
  }
  nz_svd_free(&d);
  return 1;
}

/* eigen(A) -> { {re, im}, ... }, { {vector i as {re, im} pairs}, ... } of a
 * square real matrix (a list of rows), unsorted (GSL's order). */
static int ls_eigen(lua_State *L)
{
  int m, n;
  double *A = read_matrix(L, 1, &m, &n, 0, "eigen");
  luaL_argcheck(L, m == n, 1, "a square matrix expected");
  double *w = lua_newuserdatauv(L, (2 * (size_t)n + 2 * (size_t)n * (size_t)n) * sizeof(double), 0);
  double *re = w, *im = w + n, *vr = im + n, *vi = vr + (size_t)n * (size_t)n;
  int st = nz_eigen(n, A, re, im, vr, vi);
  if (st == NZ_ENOMEM) return luaL_error(L, "eigen: not enough memory");
  if (st) return nz_lua_error(L, "eigen: the QR iteration did not converge (a matrix with entries not finite, or "
                            "badly scaled)");
  lua_createtable(L, n, 0);
  for (int i = 0; i < n; i++) {
    lua_createtable(L, 2, 0);
    lua_pushnumber(L, re[i]);
    lua_rawseti(L, -2, 1);
    lua_pushnumber(L, im[i]);
    lua_rawseti(L, -2, 2);
    lua_rawseti(L, -2, i + 1);
  }
  lua_createtable(L, n, 0);
  for (int i = 0; i < n; i++) {
    lua_createtable(L, n, 0);
    for (int r = 0; r < n; r++) {
      lua_createtable(L, 2, 0);
      lua_pushnumber(L, vr[(size_t)r * (size_t)n + (size_t)i]);
      lua_rawseti(L, -2, 1);
      lua_pushnumber(L, vi[(size_t)r * (size_t)n + (size_t)i]);
      lua_rawseti(L, -2, 2);
      lua_rawseti(L, -2, r + 1);
    }
    lua_rawseti(L, -2, i + 1);
  }
  return 2;
}

static const luaL_Reg linalg_functions[] = {
  { "lstsq", ls_lstsq }, { "singular_values", ls_singular_values }, { "eigen", ls_eigen }, { NULL, NULL }
};

/* Add the functions to the table on top of the stack (core.mech). */
void nz_lua_open_linalg(lua_State *L) { luaL_setfuncs(L, linalg_functions, 0); }
