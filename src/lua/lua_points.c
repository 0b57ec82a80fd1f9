/* lua_points.c - a trajectory's output points as C arrays (lua_points.h).
 *
 * A trajectory of many points used to hold four Lua tables per point
 * (q, q', q'', lambda), made as the loop handed the points over: with
 * 200,001 points of a Henon-Heiles run they cost 100 times the run itself
 * (the allocations, and the collector walking them).  Here a point is
 * 3k + nc doubles in one growing array, row after row; the trajectory
 * makes a point's table when tr.q[i] is read, and a column's list when
 * tr:column asks for it. */
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "lua/lua_points.h"
#include "lua/lua_util.h"

#define NZ_POINTS_METATABLE "nz.points"

struct nz_points {
  int k, nc, width;                  /* width = 3k + nc doubles per point */
  size_t n, cap;                     /* points held, room for cap */
  double *v;                         /* point i's values at v[i * width] */
};

static int points_gc(lua_State *L)
{
  nz_points *p = luaL_checkudata(L, 1, NZ_POINTS_METATABLE);
  free(p->v);
  p->v = NULL;
  p->n = p->cap = 0;
  return 0;
}

static nz_points *points_new(lua_State *L, int k, int nc)
{
  nz_points *p = lua_newuserdatauv(L, sizeof *p, 0);
  memset(p, 0, sizeof *p);
  p->k = k, p->nc = nc, p->width = 3 * k + nc;
  luaL_setmetatable(L, NZ_POINTS_METATABLE);
  return p;
}

nz_points *nz_lua_points_of(lua_State *L, int tr, int k, int nc)
{
  tr = lua_absindex(L, tr);
  nz_points *p = NULL;
  if (lua_getfield(L, tr, "_points") != LUA_TNIL) p = luaL_checkudata(L, -1, NZ_POINTS_METATABLE);
  else {
    lua_pop(L, 1);
    p = points_new(L, k, nc);
    lua_pushvalue(L, -1);
    lua_setfield(L, tr, "_points");
  }
  lua_pop(L, 1);
  if (p->k != k || p->nc != nc)
    luaL_error(L, "simulate: a point of %d coordinates and %d multipliers where the trajectory holds %d and %d",
               k, nc, p->k, p->nc);
  return p;
}

void nz_lua_points_push(lua_State *L, nz_points *p, const double *y, const double *acc)
{
  if (p->n == p->cap) {              /* doubling: realloc moves a big block by remapping it, not copying */
    size_t cap = p->cap ? 2 * p->cap : 1024;
    double *v = p->width ? realloc(p->v, cap * (size_t)p->width * sizeof(double)) : p->v;
    if (p->width && !v) luaL_error(L, "simulate: no memory for %zu output points", cap);
    p->v = v;
    p->cap = cap;
  }
  double *row = p->v + p->n * (size_t)p->width;
  size_t k = (size_t)p->k;
  if (p->width) {
    memcpy(row, y, 2 * k * sizeof(double));
    memcpy(row + 2 * k, acc, (k + (size_t)p->nc) * sizeof(double));
  }
  p->n++;
}

/* The group g (1 q, 2 q', 3 q'', 4 lambda): its first value in a row and
 * its width. */
static int group_at(lua_State *L, const nz_points *p, int arg, int *width)
{
  lua_Integer g = luaL_checkinteger(L, arg);
  luaL_argcheck(L, g >= 1 && g <= 4, arg, "a group from 1 (q) to 4 (lambda) expected");
  *width = g == 4 ? p->nc : p->k;
  return (int)(g - 1) * p->k;
}

/* points_row(points, i, g) -> point i's group g as a new list, or nil
 * when there is no point i. */
static int lp_row(lua_State *L)
{
  nz_points *p = luaL_checkudata(L, 1, NZ_POINTS_METATABLE);
  lua_Integer i = luaL_checkinteger(L, 2);
  int width, off = group_at(L, p, 3, &width);
  if (i < 1 || (size_t)i > p->n) return 0;
  const double *row = p->v + (size_t)(i - 1) * (size_t)p->width + off;
  lua_createtable(L, width, 0);
  for (int j = 0; j < width; j++) {
    lua_pushnumber(L, row[j]);
    lua_rawseti(L, -2, j + 1);
  }
  return 1;
}

/* points_column(points, g, j) -> value j of group g at every point, a new
 * list (nil when the group has no value j). */
static int lp_column(lua_State *L)
{
  nz_points *p = luaL_checkudata(L, 1, NZ_POINTS_METATABLE);
  int width, off = group_at(L, p, 2, &width);
  lua_Integer j = luaL_checkinteger(L, 3);
  if (j < 1 || j > width) return 0;
  lua_createtable(L, p->n > (size_t)INT32_MAX ? 0 : (int)p->n, 0);
  const double *v = p->v + off + (j - 1);
  for (size_t i = 0; i < p->n; i++) {
    lua_pushnumber(L, v[i * (size_t)p->width]);
    lua_rawseti(L, -2, (lua_Integer)i + 1);
  }
  return 1;
}

/* points_new(k, nc) -> an empty store; points_push(points, q, qd, qdd,
 * lambda): a point appended from Lua (a stopping event's). */
static int lp_new(lua_State *L)
{
  lua_Integer k = luaL_checkinteger(L, 1), nc = luaL_checkinteger(L, 2);
  luaL_argcheck(L, k >= 0 && k < 1 << 20, 1, "a count of coordinates expected");
  luaL_argcheck(L, nc >= 0 && nc < 1 << 20, 2, "a count of multipliers expected");
  points_new(L, (int)k, (int)nc);
  return 1;
}

static int lp_push(lua_State *L)
{
  nz_points *p = luaL_checkudata(L, 1, NZ_POINTS_METATABLE);
  int k = p->k, nc = p->nc;
  double *y = lua_newuserdatauv(L, (size_t)(3 * k + nc + 1) * sizeof(double), 0), *acc = y + 2 * k;
  for (int a = 0; a < 4; a++) {
    int width = a == 3 ? nc : k;
    double *dst = a < 2 ? y + a * k : acc + (a - 2) * k;
    luaL_checktype(L, 2 + a, LUA_TTABLE);
    for (int j = 0; j < width; j++) {
      lua_rawgeti(L, 2 + a, j + 1);
      dst[j] = luaL_checknumber(L, -1);
      lua_pop(L, 1);
    }
  }
  nz_lua_points_push(L, p, y, acc);
  return 0;
}

/* points_bytes(points) -> the bytes its array holds (room for more points
 * included): what MAX_MEMORY's estimate (options.lua) is checked against. */
static int lp_bytes(lua_State *L)
{
  nz_points *p = luaL_checkudata(L, 1, NZ_POINTS_METATABLE);
  lua_pushinteger(L, (lua_Integer)(p->cap * (size_t)p->width * sizeof(double)));
  return 1;
}

static const luaL_Reg points_functions[] = {
  { "points_new", lp_new }, { "points_bytes", lp_bytes }, { "points_push", lp_push }, { "points_row", lp_row }, { "points_column", lp_column },
  { NULL, NULL }
};

/* Add the functions to the table on top of the stack (core.mech). */
void nz_lua_open_points(lua_State *L)
{
  nz_lua_gc_metatable(L, NZ_POINTS_METATABLE, points_gc);
  luaL_setfuncs(L, points_functions, 0);
}
