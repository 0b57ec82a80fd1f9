/* session_call.h - running a function as the session runs a chunk: for the
 * session and script runner (nzlua.c) and the kernel (kernel_io.c). */
#ifndef NZ_SESSION_CALL_H
#define NZ_SESSION_CALL_H
#include <lua.h>

/* lua_pcall of the function below narg arguments, as the session runs a
 * chunk: Ctrl-C (SIGINT) raises nz.interrupted inside it and sets the flag
 * that C loops poll; an error becomes its message with a traceback.
 * *interrupted (when not NULL) says whether a SIGINT came during the call. */
int nzlua_docall(lua_State *L, int narg, int nres, int *interrupted);

/* An error message as the session prints it: the traceback only when a
 * function the user wrote is in it, and then the user's frames only.
 * Pushes the text and returns it. */
const char *nzlua_user_message(lua_State *L, const char *msg);

/* SIGINT's disposition outside calls (SIG_DFL unless the kernel says). */
void nzlua_set_idle_sigint(void (*handler)(int));

#endif
