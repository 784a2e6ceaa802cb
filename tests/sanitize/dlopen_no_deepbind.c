/* Preloaded (before libasan) into the Godot process of the sanitized harness run (scripts/test
 * --sanitize): Godot opens GDExtension libraries with RTLD_DEEPBIND, which the ASan runtime
 * refuses (google/sanitizers#611). The flag makes the library prefer its own symbols over the
 * process's; ours binds its own (hidden) symbols locally anyway, so dropping it changes nothing. */
#define _GNU_SOURCE
#include <dlfcn.h>

void* dlopen(const char* file, int flags) {
  static void* (*real_dlopen)(const char*, int);
  if (!real_dlopen) real_dlopen = (void* (*)(const char*, int))dlsym(RTLD_NEXT, "dlopen");
  return real_dlopen(file, flags & ~RTLD_DEEPBIND);
}
