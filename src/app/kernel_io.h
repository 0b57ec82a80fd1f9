/* kernel_io.h - nzlua --kernel-io: the session spoken as framed requests
 * and replies on stdin and stdout, for the Jupyter kernel (docs/kernel.md
 * has the protocol; jupyter/nzlua_kernel.py is the other end). */
#ifndef NZ_KERNEL_IO_H
#define NZ_KERNEL_IO_H
#include <stddef.h>
#include <lua.h>

/* Before the Lua libraries are opened: take stdin and stdout for the
 * protocol (private descriptors), make the C library's stdout and stderr
 * write "stream" frames, point descriptor 1 at descriptor 2 (what a child
 * process prints goes to stderr, never into a frame) and descriptor 0 at
 * /dev/null.  0, or -1 with the reason in why. */
int nz_kernel_io_begin(char *why, size_t n);

/* Serve requests until stdin ends or a shutdown request (lua/nz/session/kernel.lua
 * answers them).  Returns the Lua status of the loop. */
int nz_kernel_io_serve(lua_State *L);

#endif
