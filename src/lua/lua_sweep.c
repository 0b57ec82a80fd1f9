/* lua_sweep.c - worker processes for nz.sweep (lua/nz/motion/sweep.lua).
 *
 * A Lua state cannot be shared between threads, so a sweep runs its points
 * in processes: fork() copies the whole state, the system and the user's
 * run function with it (closures and their upvalues need no serialization),
 * and each worker talks to the parent over one Unix socket pair (a stream
 * in both directions; send with MSG_NOSIGNAL, so that a peer that died is
 * an error to report and never a SIGPIPE).  The protocol (point indices one
 * way, length-prefixed results the other) is the Lua side's.
 *
 *   core.mech.sweep_ncpu() -> the number of processors online
 *   core.mech.sweep_fork() -> pid, fd in the parent (fd non-blocking);
 *                             0, fd in the worker (fd blocking)
 *   core.mech.sweep_send(fd, s) -> true | nil, message   (all of s)
 *   core.mech.sweep_recv(fd) -> bytes ("" when none are ready on a
 *                             non-blocking fd), or nil at the end of the stream
 *   core.mech.sweep_poll(fds, ms) -> the list of fds ready to read (or
 *                             closed), or false when Ctrl-C came
 *   core.mech.sweep_close(fd), sweep_kill(pid, "term" | "kill")
 *   core.mech.sweep_wait(pid [, nohang]) -> "exit", code | "signal", n |
 *                             false (still running, with nohang)
 *   core.mech.sweep_exit(code): flush stdio and _exit (a worker never returns
 *                             into the user's script, and runs no atexit)
 *
 * The worker ignores SIGINT: Ctrl-C at a terminal reaches the whole
 * process group, and it is the parent that decides (it stops dispatching,
 * ends the workers with SIGTERM, reaps them, keeps what finished). */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>
#include <lauxlib.h>
#include "core/interrupt.h"
#include "lua/lua_sweep.h"

#define SWEEP_RECV_CHUNK 65536
#define SWEEP_MAX_FDS 4096

static int fail_errno(lua_State *L, const char *what)
{
  int e = errno;
  luaL_pushfail(L);
  lua_pushfstring(L, "%s: %s", what, strerror(e));
  return 2;
}

static int sw_ncpu(lua_State *L)
{
  long n = sysconf(_SC_NPROCESSORS_ONLN);
  lua_pushinteger(L, n > 0 ? n : 1);
  return 1;
}

static int sw_fork(lua_State *L)
{
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) return fail_errno(L, "socketpair");
  fflush(NULL);                       /* buffered output is written once, not once per process */
  pid_t pid = fork();
  if (pid < 0) {
    int e = errno;
    close(sv[0]);
    close(sv[1]);
    errno = e;
    return fail_errno(L, "fork");
  }
  if (pid == 0) {
    close(sv[0]);
    signal(SIGINT, SIG_IGN);
    signal(SIGTERM, SIG_DFL);
    lua_sethook(L, NULL, 0, 0);
    nz_interrupt_clear();
    lua_pushinteger(L, 0);
    lua_pushinteger(L, sv[1]);
    return 2;
  }
  close(sv[1]);
  int flags = fcntl(sv[0], F_GETFL);
  if (flags >= 0) fcntl(sv[0], F_SETFL, flags | O_NONBLOCK);
  lua_pushinteger(L, pid);
  lua_pushinteger(L, sv[0]);
  return 2;
}

static int sw_send(lua_State *L)
{
  int fd = (int)luaL_checkinteger(L, 1);
  size_t n;
  const char *s = luaL_checklstring(L, 2, &n);
  while (n > 0) {
    ssize_t w = send(fd, s, n, MSG_NOSIGNAL);
    if (w < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) {   /* a full socket: wait until it drains */
        struct pollfd p = { .fd = fd, .events = POLLOUT };
        poll(&p, 1, 100);
        continue;
      }
      return fail_errno(L, "send");
    }
    s += w;
    n -= (size_t)w;
  }
  lua_pushboolean(L, 1);
  return 1;
}

static int sw_recv(lua_State *L)
{
  int fd = (int)luaL_checkinteger(L, 1);
  luaL_Buffer b;
  char *p = luaL_buffinitsize(L, &b, SWEEP_RECV_CHUNK);
  ssize_t r;
  do {
    r = recv(fd, p, SWEEP_RECV_CHUNK, 0);
  } while (r < 0 && errno == EINTR && !nz_interrupt_requested());
  if (r < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) r = 0;
    else return fail_errno(L, "recv");
  } else if (r == 0) {
    luaL_pushfail(L);                  /* the other end closed */
    return 1;
  }
  luaL_pushresultsize(&b, (size_t)r);
  return 1;
}

static int sw_poll(lua_State *L)
{
  luaL_checktype(L, 1, LUA_TTABLE);
  int timeout = (int)luaL_optinteger(L, 2, -1);
  lua_Integer n = luaL_len(L, 1);
  luaL_argcheck(L, n >= 0 && n <= SWEEP_MAX_FDS, 1, "too many descriptors");
  struct pollfd *fds = lua_newuserdatauv(L, sizeof *fds * (size_t)(n > 0 ? n : 1), 0);
  for (lua_Integer i = 0; i < n; i++) {
    lua_rawgeti(L, 1, i + 1);
    fds[i].fd = (int)lua_tointeger(L, -1);
    fds[i].events = POLLIN;
    fds[i].revents = 0;
    lua_pop(L, 1);
  }
  if (nz_interrupt_requested()) {
    lua_pushboolean(L, 0);
    return 1;
  }
  int r = poll(fds, (nfds_t)n, timeout);
  if (r < 0 && errno != EINTR) return fail_errno(L, "poll");
  if (nz_interrupt_requested()) {
    lua_pushboolean(L, 0);
    return 1;
  }
  lua_newtable(L);                     /* another signal (EINTR): nothing ready, look again */
  if (r < 0) return 1;
  int k = 0;
  for (lua_Integer i = 0; i < n; i++) {
    if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) {
      lua_pushinteger(L, fds[i].fd);
      lua_rawseti(L, -2, ++k);
    }
  }
  return 1;
}

static int sw_close(lua_State *L)
{
  close((int)luaL_checkinteger(L, 1));
  return 0;
}

static int sw_kill(lua_State *L)
{
  pid_t pid = (pid_t)luaL_checkinteger(L, 1);
  static const char *const names[] = { "term", "kill", NULL };
  int which = luaL_checkoption(L, 2, "term", names);
  luaL_argcheck(L, pid > 0, 1, "a worker's process id expected");
  kill(pid, which == 0 ? SIGTERM : SIGKILL);
  return 0;
}

static int sw_wait(lua_State *L)
{
  pid_t pid = (pid_t)luaL_checkinteger(L, 1);
  int nohang = lua_toboolean(L, 2);
  luaL_argcheck(L, pid > 0, 1, "a worker's process id expected");
  int status;
  pid_t r;
  do {
    r = waitpid(pid, &status, nohang ? WNOHANG : 0);
  } while (r < 0 && errno == EINTR);
  if (r < 0) return fail_errno(L, "waitpid");
  if (r == 0) {
    lua_pushboolean(L, 0);
    return 1;
  }
  if (WIFSIGNALED(status)) {
    lua_pushliteral(L, "signal");
    lua_pushinteger(L, WTERMSIG(status));
  } else {
    lua_pushliteral(L, "exit");
    lua_pushinteger(L, WEXITSTATUS(status));
  }
  return 2;
}

static int sw_exit(lua_State *L)
{
  int code = (int)luaL_optinteger(L, 1, 0);
  fflush(NULL);
  _exit(code);
  return 0;
}

static const luaL_Reg sweep_functions[] = {
  { "sweep_ncpu", sw_ncpu }, { "sweep_fork", sw_fork }, { "sweep_send", sw_send },
  { "sweep_recv", sw_recv }, { "sweep_poll", sw_poll }, { "sweep_close", sw_close },
  { "sweep_kill", sw_kill }, { "sweep_wait", sw_wait }, { "sweep_exit", sw_exit },
  { NULL, NULL }
};

void nz_lua_open_sweep(lua_State *L)
{
  luaL_setfuncs(L, sweep_functions, 0);
}
