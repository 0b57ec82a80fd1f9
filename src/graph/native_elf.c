/* native_elf.c - a shared object's ELF headers read before it is loaded:
 * whole, and inert (the rules: native_elf.h).  Every offset and count read
 * from the file is checked against its size before it is used: the file
 * may be anything a compiler wrapper wrote. */
#include <elf.h>
#include <errno.h>
#include <link.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "graph/native_elf.h"

/* All n bytes read (out = 0) or written (out = 1) at offset at, through
 * interrupted calls; 0, or -1. */
static int transfer(int fd, void *buf, size_t n, long long at, int out)
{
  unsigned char *p = buf;
  while (n) {
    ssize_t k = out ? pwrite(fd, p, n, (off_t)at) : pread(fd, p, n, (off_t)at);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return -1;
    p += k;
    n -= (size_t)k;
    at += k;
  }
  return 0;
}

int nz_native_read_at(int fd, void *buf, size_t n, long long at) { return transfer(fd, buf, n, at, 0); }

int nz_native_write_at(int fd, const void *buf, size_t n, off_t at) { return transfer(fd, (void *)buf, n, at, 1); }

#if __SIZEOF_POINTER__ == 8
#define REL_TYPE ELF64_R_TYPE
#define SYM_TYPE ELF64_ST_TYPE
#else
#define REL_TYPE ELF32_R_TYPE
#define SYM_TYPE ELF32_ST_TYPE
#endif

/* An object's headers, as read once. */
typedef struct elf_file {
  int fd;
  long long size;
  ElfW(Ehdr) e;
} elf_file;

/* Entry i of a table of n entries of ent bytes at offset off, into out
 * (of size bytes, ent >= size); -1 when it does not lie inside the file. */
static int entry_at(const elf_file *f, long long off, long long i, size_t ent, void *out, size_t size)
{
  long long at = off + i * (long long)ent;
  if (off < 0 || ent < size || at < 0 || at + (long long)size > f->size) return -1;
  return nz_native_read_at(f->fd, out, size, at);
}

int nz_native_elf_whole(int fd, long long size, char *why, size_t whylen)
{
  ElfW(Ehdr) e;
  if (size < (long long)sizeof e || nz_native_read_at(fd, &e, sizeof e, 0) || memcmp(e.e_ident, ELFMAG, SELFMAG)) {
    snprintf(why, whylen, "not a shared object (%lld bytes, no ELF header)", size);
    return -1;
  }
  if (e.e_ident[EI_CLASS] != (sizeof(void *) == 8 ? ELFCLASS64 : ELFCLASS32) || e.e_type != ET_DYN ||
      e.e_phentsize != sizeof(ElfW(Phdr))) {
    snprintf(why, whylen, "not a shared object of this machine's kind");
    return -1;
  }
  long long ph_end = (long long)e.e_phoff + (long long)e.e_phnum * e.e_phentsize;
  long long sh_end = e.e_shnum ? (long long)e.e_shoff + (long long)e.e_shnum * e.e_shentsize : 0;
  if (ph_end > size || sh_end > size) {
    snprintf(why, whylen, "truncated: %lld bytes, its headers reach byte %lld", size,
                  ph_end > sh_end ? ph_end : sh_end);
    return -1;
  }
  for (int i = 0; i < e.e_phnum; i++) {
    ElfW(Phdr) ph;
    if (nz_native_read_at(fd, &ph, sizeof ph, (long long)e.e_phoff + (long long)i * (long long)sizeof ph)) {
      snprintf(why, whylen, "cannot read its program header %d", i);
      return -1;
    }
    if (ph.p_type == PT_LOAD && (long long)(ph.p_offset + ph.p_filesz) > size) {
      snprintf(why, whylen, "truncated: %lld bytes, a segment reaches byte %lld", size,
                    (long long)(ph.p_offset + ph.p_filesz));
      return -1;
    }
  }
  return 0;
}

/* The file offset of the virtual address addr (n bytes from it inside one
 * loaded segment's file bytes), or -1. */
static long long file_offset(const elf_file *f, ElfW(Addr) addr, long long n)
{
  for (int i = 0; i < f->e.e_phnum; i++) {
    ElfW(Phdr) ph;
    if (entry_at(f, (long long)f->e.e_phoff, i, f->e.e_phentsize, &ph, sizeof ph)) return -1;
    if (ph.p_type == PT_LOAD && addr >= ph.p_vaddr && (long long)(addr - ph.p_vaddr) + n <= (long long)ph.p_filesz)
      return (long long)ph.p_offset + (long long)(addr - ph.p_vaddr);
  }
  return -1;
}

/* The name at offset off of the string table at virtual address strtab
 * into s[n] (cut, and NUL-terminated); -1 when it lies outside the file. */
static int string_at(const elf_file *f, ElfW(Addr) strtab, ElfW(Xword) off, char *s, size_t n)
{
  long long at = file_offset(f, strtab + off, 1);
  if (at < 0) return -1;
  size_t len = (long long)(n - 1) < f->size - at ? n - 1 : (size_t)(f->size - at);
  if (nz_native_read_at(f->fd, s, len, at)) return -1;
  s[len] = 0;
  return 0;
}

/* A library the object may name: the C library and libm ("libc.so.6",
 * "libm.so.6"; musl's "libc.so"). */
static int allowed_library(const char *name)
{
  if (strncmp(name, "libc.so", 7) && strncmp(name, "libm.so", 7)) return 0;
  for (const char *p = name + 7; *p; p++)
    if (*p != '.' && (*p < '0' || *p > '9')) return 0;
  return 1;
}

/* What each dynamic tag that makes the loader run or load something is,
 * for the message (NULL: a harmless tag). */
static const char *dynamic_tag_danger(ElfW(Sxword) tag)
{
  switch (tag) {
    case DT_INIT: return "an initialisation function (DT_INIT)";
    case DT_INIT_ARRAY: return "constructors (DT_INIT_ARRAY)";
    case DT_PREINIT_ARRAY: return "pre-initialisation functions (DT_PREINIT_ARRAY)";
    case DT_FINI: return "a finalisation function (DT_FINI)";
    case DT_FINI_ARRAY: return "destructors (DT_FINI_ARRAY)";
    case DT_TEXTREL: return "text relocations (DT_TEXTREL)";
    case DT_AUXILIARY: case DT_FILTER: return "a filter library (DT_FILTER)";
    case DT_AUDIT: case DT_DEPAUDIT: return "an audit library (DT_AUDIT)";
    case DT_RPATH: case DT_RUNPATH: return "a library search path (DT_RUNPATH)";
    default: return NULL;
  }
}

/* The dynamic section's tables the scans of relocations and symbols need. */
typedef struct dyn_tables {
  ElfW(Addr) strtab, symtab, hash, gnu_hash, rel[3];
  ElfW(Xword) relsz[3], relent[3], syment;
} dyn_tables;

/* Notes the dynamic entry d in *t: the tables and the relocations (DT_RELA,
 * DT_REL, DT_JMPREL: RELA or REL as DT_PLTREL says). */
static void note_table(const ElfW(Dyn) *d, dyn_tables *t)
{
  switch (d->d_tag) {
    case DT_STRTAB: t->strtab = d->d_un.d_ptr; break;
    case DT_SYMTAB: t->symtab = d->d_un.d_ptr; break;
    case DT_SYMENT: t->syment = d->d_un.d_val; break;
    case DT_HASH: t->hash = d->d_un.d_ptr; break;
    case DT_GNU_HASH: t->gnu_hash = d->d_un.d_ptr; break;
    case DT_RELA: t->rel[0] = d->d_un.d_ptr; t->relent[0] = sizeof(ElfW(Rela)); break;
    case DT_RELASZ: t->relsz[0] = d->d_un.d_val; break;
    case DT_REL: t->rel[1] = d->d_un.d_ptr; t->relent[1] = sizeof(ElfW(Rel)); break;
    case DT_RELSZ: t->relsz[1] = d->d_un.d_val; break;
    case DT_JMPREL: t->rel[2] = d->d_un.d_ptr; break;
    case DT_PLTRELSZ: t->relsz[2] = d->d_un.d_val; break;
    case DT_PLTREL: t->relent[2] = d->d_un.d_val == DT_REL ? sizeof(ElfW(Rel)) : sizeof(ElfW(Rela)); break;
    default: break;
  }
}

/* The dynamic section at [off, off + n): a tag that runs or loads code, or a
 * library other than libc and libm, refused; the tables noted in *t. */
static int check_dynamic(const elf_file *f, long long off, long long n, dyn_tables *t, char *why, size_t whylen)
{
  long long count = n / (long long)sizeof(ElfW(Dyn));
  for (int pass = 0; pass < 2; pass++)   /* DT_STRTAB may come after DT_NEEDED */
    for (long long i = 0; i < count; i++) {
      ElfW(Dyn) d;
      if (entry_at(f, off, i, sizeof d, &d, sizeof d)) {
        snprintf(why, whylen, "its dynamic section lies outside the file");
        return -1;
      }
      if (d.d_tag == DT_NULL) break;
      const char *danger = dynamic_tag_danger(d.d_tag);
      if (pass == 0) {
        if (danger) snprintf(why, whylen, "has %s", danger);
        else if (d.d_tag == DT_FLAGS && (d.d_un.d_val & DF_TEXTREL))
          snprintf(why, whylen, "has text relocations (DF_TEXTREL)");
        else if (d.d_tag == DT_FLAGS_1 && (d.d_un.d_val & DF_1_INITFIRST))
          snprintf(why, whylen, "asks to be initialised first (DF_1_INITFIRST)");
        else {
          note_table(&d, t);
          continue;
        }
        return -1;
      }
      if (d.d_tag != DT_NEEDED) continue;
      char name[256];
      if (string_at(f, t->strtab, d.d_un.d_val, name, sizeof name)) {
        snprintf(why, whylen, "names a library whose name lies outside the file");
        return -1;
      }
      if (!allowed_library(name)) {
        snprintf(why, whylen, "needs the library '%s' (only the C library and libm may be loaded with it)", name);
        return -1;
      }
    }
  return 0;
}

#if defined(__x86_64__)
#define IRELATIVE R_X86_64_IRELATIVE
#elif defined(__aarch64__)
#define IRELATIVE R_AARCH64_IRELATIVE
#elif defined(__i386__)
#define IRELATIVE R_386_IRELATIVE
#else
#define IRELATIVE (-1)
#endif

/* The relocation tables: one that calls a resolver of the object's at load
 * time (IRELATIVE) refused. */
static int check_relocations(const elf_file *f, const dyn_tables *t, char *why, size_t whylen)
{
  for (int k = 0; k < 3; k++) {
    if (!t->rel[k] || !t->relsz[k]) continue;
    size_t ent = t->relent[k] ? t->relent[k] : sizeof(ElfW(Rela));
    long long off = file_offset(f, t->rel[k], (long long)t->relsz[k]);
    for (long long i = 0; i < (long long)(t->relsz[k] / ent); i++) {
      ElfW(Rel) r;   /* a Rela begins as a Rel does */
      if (off < 0 || entry_at(f, off, i, ent, &r, sizeof r)) {
        snprintf(why, whylen, "its relocations lie outside the file");
        return -1;
      }
      if ((long long)REL_TYPE(r.r_info) == IRELATIVE) {
        snprintf(why, whylen, "has an indirect function whose resolver runs when it is loaded (IRELATIVE)");
        return -1;
      }
    }
  }
  return 0;
}

/* The number of dynamic symbols: DT_HASH's chain count, else the end of
 * the last chain of DT_GNU_HASH; -1 when the tables lie outside the file. */
static long long symbol_count(const elf_file *f, const dyn_tables *t)
{
  uint32_t w[4];
  long long at;
  if (t->hash) {
    if ((at = file_offset(f, t->hash, 8)) < 0 || nz_native_read_at(f->fd, w, 8, at)) return -1;
    return w[1];
  }
  if (!t->gnu_hash) return 0;
  if ((at = file_offset(f, t->gnu_hash, 16)) < 0 || nz_native_read_at(f->fd, w, 16, at)) return -1;
  uint32_t nbuckets = w[0], first = w[1];
  long long buckets = at + 16 + (long long)w[2] * (long long)sizeof(ElfW(Addr)), last = 0;
  for (uint32_t b = 0; b < nbuckets; b++) {
    uint32_t v;
    if (entry_at(f, buckets, b, 4, &v, 4)) return -1;
    if (v > last) last = v;
  }
  if (last < first) return first;
  long long chains = buckets + 4LL * nbuckets;
  for (uint32_t v = 0;; last++) {   /* a chain ends with its low bit set */
    if (entry_at(f, chains, last - first, 4, &v, 4)) return -1;
    if (v & 1) return last + 1;
  }
}

/* The dynamic symbols: an indirect function defined here (dlsym would run
 * its resolver) refused. */
static int check_symbols(const elf_file *f, const dyn_tables *t, char *why, size_t whylen)
{
  long long n = symbol_count(f, t), off = t->symtab ? file_offset(f, t->symtab, 1) : -1;
  if (n > 0 && off < 0) n = -1;
  for (long long i = 0; i < n; i++) {
    ElfW(Sym) s;
    if (entry_at(f, off, i, t->syment ? t->syment : sizeof s, &s, sizeof s)) n = -1;
    else if (SYM_TYPE(s.st_info) == STT_GNU_IFUNC && s.st_shndx != SHN_UNDEF) {
      snprintf(why, whylen, "has an indirect function whose resolver runs when it is looked up (IFUNC)");
      return -1;
    }
  }
  if (n < 0) {
    snprintf(why, whylen, "its symbol table lies outside the file");
    return -1;
  }
  return 0;
}

/* Sections that hold constructors or destructors, by type or by name:
 * refused even where the dynamic section does not point at them. */
static int check_sections(const elf_file *f, char *why, size_t whylen)
{
  const ElfW(Ehdr) *e = &f->e;
  ElfW(Shdr) names;
  int have_names = e->e_shnum && e->e_shstrndx < e->e_shnum &&
                   !entry_at(f, (long long)e->e_shoff, e->e_shstrndx, e->e_shentsize, &names, sizeof names);
  for (int i = 0; i < e->e_shnum; i++) {
    ElfW(Shdr) sh;
    char name[32] = "";
    if (entry_at(f, (long long)e->e_shoff, i, e->e_shentsize, &sh, sizeof sh)) {
      snprintf(why, whylen, "its section header %d lies outside the file", i);
      return -1;
    }
    if (have_names && (long long)(names.sh_offset + sh.sh_name) < f->size) {
      long long at = (long long)(names.sh_offset + sh.sh_name);
      size_t len = f->size - at < (long long)sizeof name - 1 ? (size_t)(f->size - at) : sizeof name - 1;
      if (nz_native_read_at(f->fd, name, len, at)) name[0] = 0;
      name[len] = 0;
    }
    static const char *const bad[] = { ".init", ".fini", ".init_array", ".fini_array", ".preinit_array",
                                       ".ctors", ".dtors" };
    int hit = sh.sh_type == SHT_INIT_ARRAY || sh.sh_type == SHT_FINI_ARRAY || sh.sh_type == SHT_PREINIT_ARRAY;
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) hit = hit || !strcmp(name, bad[k]);
    if (hit) {
      snprintf(why, whylen, "has a section of code run at load or unload ('%s')", name[0] ? name : "?");
      return -1;
    }
  }
  return 0;
}

int nz_native_elf_inert(int fd, long long size, char *why, size_t whylen)
{
  elf_file f;
  memset(&f, 0, sizeof f);
  f.fd = fd;
  f.size = size;
  if (nz_native_read_at(fd, &f.e, sizeof f.e, 0)) {
    snprintf(why, whylen, "has no ELF header");
    return -1;
  }
  int stack = 0, dynamics = 0;
  dyn_tables t;
  memset(&t, 0, sizeof t);
  for (int i = 0; i < f.e.e_phnum; i++) {
    ElfW(Phdr) ph;
    if (entry_at(&f, (long long)f.e.e_phoff, i, f.e.e_phentsize, &ph, sizeof ph)) {
      snprintf(why, whylen, "its program header %d lies outside the file", i);
      return -1;
    }
    if (ph.p_type == PT_GNU_STACK && (ph.p_flags & PF_X)) {
      snprintf(why, whylen, "asks for an executable stack (PT_GNU_STACK with PF_X)");
      return -1;
    }
    stack |= ph.p_type == PT_GNU_STACK;
    if (ph.p_type == PT_DYNAMIC && dynamics++) {
      snprintf(why, whylen, "has two dynamic sections");
      return -1;
    }
    if (ph.p_type == PT_DYNAMIC && check_dynamic(&f, (long long)ph.p_offset, (long long)ph.p_filesz, &t, why, whylen))
      return -1;
  }
  if (!stack) {
    snprintf(why, whylen, "does not say its stack is not executable (no PT_GNU_STACK: the loader would make "
                  "every stack executable)");
    return -1;
  }
  if (check_relocations(&f, &t, why, whylen) || check_symbols(&f, &t, why, whylen)) return -1;
  return check_sections(&f, why, whylen);
}
