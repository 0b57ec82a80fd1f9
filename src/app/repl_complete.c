/* repl_complete.c - tab completion for the nzlua session.
 *
 * The word before the cursor is a dotted path such as "nz.si" or "sys:re".
 * Everything before the last '.' or ':' is looked up from the global table;
 * the candidates are the string keys of the value found (when a table) and of
 * its metatable's __index table (methods of userdata such as jets and of
 * objects built on tables), functions only after ':'.  A bare word completes
 * against globals and Lua's keywords.  Lookups run under lua_pcall, so a
 * misbehaving __index can never break the prompt. */
#include <stdlib.h>
#include <string.h>
#include <stdio.h>
#include <readline/readline.h>
#include <lauxlib.h>
#include "app/repl_complete.h"

static lua_State *complete_L;

static const char *const keywords[] = {
  "and", "break", "do", "else", "elseif", "end", "false", "for", "function", "goto", "if",
  "in", "local", "nil", "not", "or", "repeat", "return", "then", "true", "until", "while", NULL
};

typedef struct candidates {
  char **items;
  size_t n, cap;
} candidates;

static void add_candidate(candidates *c, const char *prefix, size_t plen, const char *key)
{
  if (c->n == c->cap) {
    size_t cap = c->cap ? 2 * c->cap : 64;
    char **p = realloc(c->items, cap * sizeof *p);
    if (!p) return;
    c->items = p;
    c->cap = cap;
  }
  size_t klen = strlen(key);
  char *s = malloc(plen + klen + 1);
  if (!s) return;
  memcpy(s, prefix, plen);
  memcpy(s + plen, key, klen + 1);
  c->items[c->n++] = s;
}

static int is_identifier(const char *s)
{
  if (!(*s == '_' || (*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z'))) return 0;
  for (s++; *s; s++)
    if (!(*s == '_' || (*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z') || (*s >= '0' && *s <= '9')))
      return 0;
  return 1;
}

/* Add the keys of the table on top of the stack that start with `partial`. */
static void add_keys(lua_State *L, candidates *c, const char *prefix, size_t plen,
                     const char *partial, int functions_only)
{
  size_t len = strlen(partial);
  lua_pushnil(L);
  while (lua_next(L, -2)) {
    if (lua_type(L, -2) == LUA_TSTRING) {
      const char *key = lua_tostring(L, -2);
      if (is_identifier(key) && strncmp(key, partial, len) == 0 &&
          (!functions_only || lua_type(L, -1) == LUA_TFUNCTION))
        add_candidate(c, prefix, plen, key);
    }
    lua_pop(L, 1);
  }
}

/* Protected: args (light userdata candidates, word). */
static int collect(lua_State *L)
{
  candidates *c = lua_touserdata(L, 1);
  const char *word = lua_tostring(L, 2);
  const char *sep = NULL;
  for (const char *p = word; *p; p++)
    if (*p == '.' || *p == ':') sep = p;
  if (!sep) {
    for (int i = 0; keywords[i]; i++)
      if (strncmp(keywords[i], word, strlen(word)) == 0) add_candidate(c, "", 0, keywords[i]);
    lua_pushglobaltable(L);
    add_keys(L, c, "", 0, word, 0);
    return 0;
  }
  /* Walk the path before the separator from the global table. */
  lua_pushglobaltable(L);
  const char *start = word;
  while (start < sep) {
    const char *end = start;
    while (end < sep && *end != '.' && *end != ':') end++;
    lua_pushlstring(L, start, (size_t)(end - start));
    if (!lua_istable(L, -2) && !lua_isuserdata(L, -2)) return 0;
    lua_gettable(L, -2);
    lua_remove(L, -2);
    start = end + 1;
  }
  int functions_only = *sep == ':';
  size_t plen = (size_t)(sep - word) + 1;
  const char *partial = sep + 1;
  /* The value itself, then the __index tables up a short chain of classes. */
  for (int depth = 0; depth < 4; depth++) {
    if (lua_istable(L, -1)) add_keys(L, c, word, plen, partial, functions_only);
    if (!lua_getmetatable(L, -1)) break;
    lua_getfield(L, -1, "__index");
    lua_remove(L, -2);
    if (!lua_istable(L, -1)) break;
  }
  return 0;
}

/* The candidates for word into *c, collected under a protected call (an
 * error in a user's __index cannot escape into readline), the stack as it
 * was. */
static void collect_into(lua_State *L, candidates *c, const char *word)
{
  int top = lua_gettop(L);
  lua_pushcfunction(L, collect);
  lua_pushlightuserdata(L, c);
  lua_pushstring(L, word);
  lua_pcall(L, 2, 0, 0);
  lua_settop(L, top);
}

static candidates current;
static size_t current_next;

static char *generator(const char *text, int state)
{
  (void)text;
  if (state == 0) current_next = 0;
  if (current_next < current.n) {
    char *s = current.items[current_next];
    current.items[current_next++] = NULL;
    return s;                          /* readline frees it */
  }
  return NULL;
}

static char **attempt(const char *text, int start, int end)
{
  (void)start;
  (void)end;
  lua_State *L = complete_L;
  for (size_t i = current_next; i < current.n; i++) free(current.items[i]);
  current.n = 0;
  current_next = 0;
  rl_attempted_completion_over = 1;    /* never fall back to file names */
  rl_completion_suppress_append = 1;
  collect_into(L, &current, text);
  if (current.n == 0) return NULL;
  return rl_completion_matches(text, generator);
}

/* '.' and ':' belong to the word: "sys:re<TAB>" completes methods. */
static const char word_breaks[] = " \t\n\"\\'`@$><=;|&{(+-*/%^,[]~#";

void nz_complete_install(lua_State *L)
{
  complete_L = L;
  rl_readline_name = "nzlua";
  rl_attempted_completion_function = attempt;
  rl_basic_word_break_characters = (char *)word_breaks;
  rl_completer_word_break_characters = rl_basic_word_break_characters;
}

void nz_complete_push(lua_State *L, const char *word)
{
  candidates c = { 0 };
  collect_into(L, &c, word);
  lua_createtable(L, (int)c.n, 0);
  for (size_t i = 0; i < c.n; i++) {
    lua_pushstring(L, c.items[i]);
    lua_rawseti(L, -2, (lua_Integer)i + 1);
  }
  for (size_t i = 0; i < c.n; i++) free(c.items[i]);
  free(c.items);
}

size_t nz_complete_word_start(const char *line, size_t end)
{
  size_t i = end;
  while (i > 0 && !strchr(word_breaks, line[i - 1])) i--;
  return i;
}
