/* embedded.h - the Lua half of the nz module, compiled into the C library
 * (the table is generated from the files in lua/nz by tools/embed.lua). */
#ifndef NZ_EMBEDDED_H
#define NZ_EMBEDDED_H
#include <stddef.h>

typedef struct nz_embedded_module {
  const char *name;                /* module name, "nz.session.help" */
  const char *chunkname;           /* "@lua/nz/session/help.lua", for errors */
  const unsigned char *source;
  size_t size;
} nz_embedded_module;

extern const nz_embedded_module nz_embedded_modules[];

#endif
