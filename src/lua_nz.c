/* lua_nz.c - luaopen_nz: the entry point of the nz module.
 *
 * The same function opens the module inside nzlua and from any Lua 5.4
 * program (`require "nz"` loads nz.so).  It builds the table of C functions
 * ("nz.core"), makes the embedded Lua modules require-able through
 * package.preload, and returns what lua/nz/init.lua makes of the core. */
#include <lua.h>
#include <lauxlib.h>
#include "embedded.h"
#include <gsl/gsl_errno.h>
#include "lua_jet.h"
#include "lua_special.h"
#include "lua_system.h"
#include "nz.h"

static int load_embedded(lua_State *L)
{
  const nz_embedded_module *m = lua_touserdata(L, lua_upvalueindex(1));
  if (luaL_loadbufferx(L, (const char *)m->source, m->size, m->chunkname, "t") != LUA_OK)
    return lua_error(L);
  lua_insert(L, 1);                     /* chunk, module name, ... */
  lua_call(L, lua_gettop(L) - 1, 1);
  return 1;
}

static void preload_embedded(lua_State *L)
{
  luaL_getsubtable(L, LUA_REGISTRYINDEX, LUA_PRELOAD_TABLE);
  for (const nz_embedded_module *m = nz_embedded_modules; m->name; m++) {
    lua_pushlightuserdata(L, (void *)m);
    lua_pushcclosure(L, load_embedded, 1);
    lua_setfield(L, -2, m->name);
  }
  lua_pop(L, 1);
}

static int open_core(lua_State *L)
{
  lua_newtable(L);
  nz_lua_open_jet(L);
  nz_lua_open_system(L);
  nz_lua_open_special(L);
  lua_pushstring(L, NZ_VERSION);
  lua_setfield(L, -2, "version");
  return 1;
}

int luaopen_nz(lua_State *L)
{
  gsl_set_error_handler_off();     /* GSL's default handler aborts: statuses instead */
  preload_embedded(L);
  luaL_requiref(L, "nz.core", open_core, 0);
  lua_pop(L, 1);
  lua_getglobal(L, "require");
  lua_pushstring(L, "nz.init");
  lua_call(L, 1, 1);
  return 1;
}
