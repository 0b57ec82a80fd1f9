/* repl_complete.h - tab completion of globals, fields and methods for the
 * nzlua session (readline) and the Jupyter kernel. */
#ifndef NZ_REPL_COMPLETE_H
#define NZ_REPL_COMPLETE_H
#include <lua.h>

/* Install the completer; it looks names up in L's global table. */
void nz_complete_install(lua_State *L);

/* The same completer for other front-ends (the Jupyter kernel): push a list
 * of the completions of `word` (a dotted path such as "nz.si", "sys:re",
 * or a bare name), each the whole word completed. */
void nz_complete_push(lua_State *L, const char *word);

/* Where the word that ends at byte `end` of `line` starts: after the last
 * character that breaks words for the session's Tab. */
size_t nz_complete_word_start(const char *line, size_t end);

#endif
