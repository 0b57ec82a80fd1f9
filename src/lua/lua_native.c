/* lua_native.c - nz.cache: where the machine code of recorded systems is
 * kept, what is in it, emptying it (the rules: src/graph/native_object.h). */
#include <stdio.h>
#include <lua.h>
#include <lauxlib.h>
#include "graph/native_cache.h"
#include "lua/lua_native.h"

/* The directory, or raise the reason there is none. */
static const char *cache_dir(lua_State *L, char *buf, size_t n)
{
  char why[400];
  if (!nz_native_cache_dir(buf, n, why, sizeof why)) luaL_error(L, "%s", why);
  return buf;
}

/* nz.cache.dir() -> the directory, or nil and why there is none. */
static int cache_dir_fn(lua_State *L)
{
  char buf[4096], why[400];
  if (nz_native_cache_dir(buf, sizeof buf, why, sizeof why)) {
    lua_pushstring(L, buf);
    return 1;
  }
  lua_pushnil(L);
  lua_pushstring(L, why);
  return 2;
}

/* nz.cache.info() -> {dir, objects, sources, others, bytes, limit, trusted, why} */
static int cache_info(lua_State *L)
{
  char buf[4096], why[400];
  nz_native_cache_stat st;
  const char *dir = cache_dir(L, buf, sizeof buf);
  if (nz_native_cache_info(dir, &st, why, sizeof why)) return luaL_error(L, "%s", why);
  lua_createtable(L, 0, 8);
  lua_pushstring(L, dir);
  lua_setfield(L, -2, "dir");
  const struct { const char *name; long long v; } counts[] = {
    { "objects", st.objects }, { "sources", st.sources }, { "others", st.others }, { "bytes", st.bytes },
    { "limit", st.limit } };
  for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++) {
    lua_pushinteger(L, (lua_Integer)counts[i].v);
    lua_setfield(L, -2, counts[i].name);
  }
  lua_pushboolean(L, st.trusted);
  lua_setfield(L, -2, "trusted");
  if (!st.trusted) {
    lua_pushstring(L, st.why);
    lua_setfield(L, -2, "why");
  }
  return 1;
}

/* nz.cache.clear() -> the number of files removed */
static int cache_clear(lua_State *L)
{
  char buf[4096], why[400];
  int n = nz_native_cache_clear(cache_dir(L, buf, sizeof buf), why, sizeof why);
  if (n < 0) return luaL_error(L, "%s", why);
  lua_pushinteger(L, n);
  return 1;
}

static void notice(const char *line)
{
  fprintf(stderr, "nzlua: %s\n", line);
  fflush(stderr);
}

void nz_lua_open_native(lua_State *L)
{
  static const luaL_Reg fns[] = { { "dir", cache_dir_fn }, { "info", cache_info }, { "clear", cache_clear },
                                  { NULL, NULL } };
  luaL_newlib(L, fns);
  lua_setfield(L, -2, "cache");
  nz_native_set_notice(notice);
}
