/* session_call.c - a function run as the session runs a chunk, shared by
 * the session and script runner (nzlua.c) and the kernel (kernel_io.c):
 * under lua_pcall with a message handler that turns any error into text
 * with a traceback; Ctrl-C during the call only installs a hook that raises
 * the interrupt object nz.interrupted inside the VM (and sets the flag C
 * loops poll), and resets the signal so that a second Ctrl-C really kills
 * (the design of the standalone lua interpreter, lua.c). */
#include <signal.h>
#include <stdio.h>
#include <string.h>

#include <lua.h>
#include <lauxlib.h>

#include "core/interrupt.h"
#include "lua/lua_util.h"
#include "app/session_call.h"

static lua_State *globalL = NULL;
/* SIGINT's disposition between calls: the default (Ctrl-C ends a script);
 * the kernel ignores it while it waits for a request (app/kernel_io.c). */
static void (*idle_sigint)(int) = SIG_DFL;

/* ------------------------------------------------------------------ */
/* Interrupts                                                           */

static void lstop(lua_State *L, lua_Debug *ar)
{
  (void)ar;
  lua_sethook(L, NULL, 0, 0);
  nz_lua_raise_interrupt(L);
}

static void laction(int sig)
{
  int flag = LUA_MASKCALL | LUA_MASKRET | LUA_MASKLINE | LUA_MASKCOUNT;
  signal(sig, SIG_DFL);          /* a second Ctrl-C kills the process */
  nz_interrupt_request();        /* C loops poll this and stop cleanly */
  lua_sethook(globalL, lstop, flag, 1);
}

/* ------------------------------------------------------------------ */
/* Messages                                                             */

/* Message handler: any error object to text, plus a traceback. */
static int msghandler(lua_State *L)
{
  if (nz_lua_is_interrupt(L, 1)) {
    luaL_traceback(L, L, "interrupted!", 1);
    return 1;
  }
  const char *msg = lua_tostring(L, 1);
  if (msg == NULL) {
    if (luaL_callmeta(L, 1, "__tostring") && lua_type(L, -1) == LUA_TSTRING) return 1;
    msg = lua_pushfstring(L, "(error object is a %s value)", luaL_typename(L, 1));
  }
  luaL_traceback(L, L, msg, 1);
  return 1;
}

/* A line of a traceback that is not the user's code: C functions, nz's own
 * Lua files (embedded as lua/nz/NAME.lua, or a checkout's: their messages
 * name the user's line already) and the marks of tail calls. */
static int frame_is_library(const char *s, size_t n)
{
  if (n >= 4 && strncmp(s, "[C]:", 4) == 0) return 1;
  if (n >= 7 && strncmp(s, "lua/nz/", 7) == 0) return 1;
  if (memmem(s, n, "/lua/nz/", 8)) return 1;
  return memmem(s, n, "(...tail calls...)", 18) != NULL;
}

/* Whether a traceback shows a function the user (or a script) wrote, not
 * only the chunk that was run (the typed line, the script's main chunk)
 * and library frames: only then is it worth reading. */
static int traceback_is_deep(const char *msg)
{
  const char *tb = strstr(msg, "\nstack traceback:\n");
  if (!tb) return 0;
  for (const char *line = strchr(tb + 1, '\n'); line; line = strchr(line + 1, '\n')) {
    const char *s = line + 1;
    while (*s == '\t' || *s == ' ') s++;
    if (!*s) continue;
    const char *end = strchr(s, '\n');
    size_t n = end ? (size_t)(end - s) : strlen(s);
    if (frame_is_library(s, n)) continue;
    if (n >= 13 && memmem(s, n, "in main chunk", 13)) continue;
    return 1;
  }
  return 0;
}

/* The message to print: without its traceback unless a function the user
 * wrote is in it, and then with the user's frames only (the library's
 * frames say nothing the message does not).  Pushes the text. */
static const char *user_message(lua_State *L, const char *msg)
{
  const char *tb = strstr(msg, "\nstack traceback:\n");
  if (!tb) return lua_pushstring(L, msg);
  luaL_Buffer b;
  luaL_buffinit(L, &b);
  luaL_addlstring(&b, msg, (size_t)(tb - msg));
  if (traceback_is_deep(msg)) {
    luaL_addstring(&b, "\nstack traceback:");
    for (const char *line = strchr(tb + 1, '\n'); line; line = strchr(line + 1, '\n')) {
      const char *s = line + 1, *end = strchr(s, '\n');
      size_t n = end ? (size_t)(end - s) : strlen(s);
      const char *v = s;
      while (v < s + n && (*v == '\t' || *v == ' ')) v++;
      if (v == s + n || frame_is_library(v, (size_t)(s + n - v))) continue;
      luaL_addchar(&b, '\n');
      luaL_addlstring(&b, s, n);
    }
  }
  luaL_pushresult(&b);
  return lua_tostring(L, -1);
}

const char *nzlua_user_message(lua_State *L, const char *msg) { return user_message(L, msg); }

int nzlua_docall(lua_State *L, int narg, int nres, int *interrupted)
{
  int base = lua_gettop(L) - narg;
  lua_pushcfunction(L, msghandler);
  lua_insert(L, base);
  globalL = L;
  nz_interrupt_clear();
  signal(SIGINT, laction);
  int status = lua_pcall(L, narg, nres, base);
  signal(SIGINT, idle_sigint);
  lua_sethook(L, NULL, 0, 0);   /* a Ctrl-C that came too late to matter */
  if (interrupted) *interrupted = nz_interrupt_requested();
  nz_interrupt_clear();
  lua_remove(L, base);
  return status;
}

void nzlua_set_idle_sigint(void (*handler)(int))
{
  idle_sigint = handler;
  signal(SIGINT, handler);
}
