/* native_elf.h - what a shared object would do when the dynamic loader
 * takes it, read from its ELF headers before dlopen ever sees it.
 *
 * dlopen runs code of the object's before the caller can look at a single
 * symbol: its constructors (DT_INIT, DT_INIT_ARRAY, DT_PREINIT_ARRAY), the
 * resolvers of its indirect functions (IFUNC symbols, IRELATIVE
 * relocations), and the constructors of every library it names (DT_NEEDED,
 * filters, audit libraries, found along its own search path).  Its
 * destructors (DT_FINI, DT_FINI_ARRAY) run at dlclose.  Text relocations
 * make its code writable while it is relocated, and an executable stack
 * (PT_GNU_STACK with PF_X, or no PT_GNU_STACK at all) makes the whole
 * process's stacks executable.  The objects nzlua generates have none of
 * these: they are plain functions on doubles, linked with -nostartfiles (so
 * that gcc's start files add no frame_dummy constructor and no _init/_fini)
 * against the C library and libm alone.  So an object that has any of them
 * was not made by nzlua's generator as nzlua runs it, whatever CC did, and
 * is refused before it is loaded.
 *
 * Plain C: no Lua, no printing, and no other file of nzlua's (the cache
 * uses it, it uses nothing of the cache's). */
#ifndef NZ_NATIVE_ELF_H
#define NZ_NATIVE_ELF_H

#include <stddef.h>
#include <sys/types.h>

/* All n bytes read at offset at (or written: nz_native_write_at), through
 * interrupted calls; 0, or -1 with errno (an error, or the file ends
 * first).  The cache's files are read and written with these too. */
int nz_native_read_at(int fd, void *buf, size_t n, long long at);
int nz_native_write_at(int fd, const void *buf, size_t n, off_t at);

/* The first size bytes of fd hold a whole shared object of this machine's
 * class: its program headers and every loaded segment, and its section
 * headers, lie inside them (a truncated object faults inside dlopen).  0,
 * or -1 with the reason in why. */
int nz_native_elf_whole(int fd, long long size, char *why, size_t whylen);

/* The same object (already found whole) runs no code of its own when it
 * is loaded or unloaded, names no library but the C library and libm, has
 * no text relocation and asks for no executable stack (see above).  0, or
 * -1 with what it has in why ("a constructor (DT_INIT_ARRAY)"). */
int nz_native_elf_inert(int fd, long long size, char *why, size_t whylen);

#endif
