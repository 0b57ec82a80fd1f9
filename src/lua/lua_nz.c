/* lua_nz.c - luaopen_nz: the entry point of the nz module.
 *
 * The same function opens the module inside nzlua and from any Lua 5.4
 * program (`require "nz"` loads nz.so).  It builds the table of C functions
 * ("nz.core"), makes the embedded Lua modules require-able through
 * package.preload, and returns what lua/nz/init.lua makes of the core. */
#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <lua.h>
#include <lauxlib.h>
#include "lua/embedded.h"
#include <gsl/gsl_errno.h>
#include "lua/lua_constraints.h"
#include "lua/lua_contact.h"
#include "lua/lua_dualjet.h"
#include "lua/lua_graph.h"
#include "lua/lua_jet.h"
#include "lua/lua_linalg.h"
#include "lua/lua_native.h"
#include "lua/lua_roots.h"
#include "lua/lua_ode.h"
#include "lua/lua_points.h"
#include "lua/lua_series.h"
#include "lua/lua_special.h"
#include "lua/lua_sweep.h"
#include "lua/lua_system.h"
#include "lua/lua_taylor.h"
#include "lua/lua_util.h"
#include "lua/nz.h"

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

/* temp_beside(path) -> name: a new empty file "path.XXXXXX" in the same
 * directory (so that renaming it onto path is atomic), with the permissions
 * a new file gets; nil and the reason when it cannot be made.  Writers fill
 * it and rename it into place, so that an interrupt or a kill never leaves
 * a truncated file under the name the user gave. */
static int temp_beside(lua_State *L)
{
  const char *path = luaL_checkstring(L, 1);
  lua_pushfstring(L, "%s.XXXXXX", path);
  char *name = (char *)lua_newuserdatauv(L, lua_rawlen(L, -1) + 1, 0);
  memcpy(name, lua_tostring(L, -2), lua_rawlen(L, -2) + 1);
  int fd = mkstemp(name);
  if (fd < 0) {
    luaL_pushfail(L);
    lua_pushstring(L, strerror(errno));
    return 2;
  }
  mode_t mask = umask(0);            /* mkstemp makes 0600; a new file is 0666 & ~umask */
  umask(mask);
  fchmod(fd, 0666 & ~mask);
  close(fd);
  lua_pushstring(L, name);
  return 1;
}

/* hold_term(true | false): SIGTERM held while a file is written beside its
 * target.  A kill then lets the write and the rename finish (the user gets
 * the complete file, and no temporary file is left behind) and takes effect
 * at hold_term(false), with the handler that was there before (by default
 * the process ends with 128 + SIGTERM).  SIGKILL cannot be held. */
static volatile sig_atomic_t term_pending = 0;
static struct sigaction term_before;
static int term_holding = 0;

static void term_hold_handler(int sig)
{
  (void)sig;
  term_pending = 1;
}

static int hold_term(lua_State *L)
{
  int hold = lua_toboolean(L, 1);
  if (hold && !term_holding) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = term_hold_handler;
    sigemptyset(&sa.sa_mask);
    term_pending = 0;
    if (sigaction(SIGTERM, &sa, &term_before) == 0) term_holding = 1;
  } else if (!hold && term_holding) {
    sigaction(SIGTERM, &term_before, NULL);
    term_holding = 0;
    if (term_pending) {
      term_pending = 0;
      raise(SIGTERM);
    }
  }
  return 0;
}

static int open_core(lua_State *L)
{
  lua_newtable(L);
  nz_lua_open_jet(L);
  /* core.mech: the mechanics and everything built on it; each binding adds
   * its functions to the table on top, and none registers another. */
  lua_newtable(L);
  nz_lua_open_system(L);
  nz_lua_open_constraints(L);
  nz_lua_open_series(L);
  nz_lua_open_linalg(L);
  nz_lua_open_roots(L);
  nz_lua_open_ode(L);
  nz_lua_open_points(L);          /* a trajectory's output points */
  nz_lua_open_taylor(L);
  nz_lua_open_contact(L);        /* unilateral contacts for the integrators */
  nz_lua_open_sweep(L);          /* worker processes of nz.sweep */
  nz_lua_open_graph(L);          /* the recorder's constructor is internal */
  lua_setfield(L, -2, "mech");
  nz_lua_open_dualjet(L);        /* after the jets (its branches call them) and core.mech */
  nz_lua_open_special(L);
  nz_lua_open_native(L);         /* nz.cache: the machine code's cache */
  lua_pushstring(L, NZ_VERSION);
  lua_setfield(L, -2, "version");
  lua_getfield(L, -1, "mech");          /* the library's own services */
  lua_pushcfunction(L, temp_beside);
  lua_setfield(L, -2, "temp_beside");
  lua_pushcfunction(L, hold_term);
  lua_setfield(L, -2, "hold_term");
  lua_pop(L, 1);
  nz_lua_push_interrupt(L);       /* nz.interrupted: what Ctrl-C raises */
  lua_setfield(L, -2, "interrupted");
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
