/* repl_complete.h - tab completion of globals, fields and methods for the
 * nzlua session (readline). */
#ifndef NZ_REPL_COMPLETE_H
#define NZ_REPL_COMPLETE_H
#include <lua.h>

/* Install the completer; it looks names up in L's global table. */
void nz_complete_install(lua_State *L);

#endif
