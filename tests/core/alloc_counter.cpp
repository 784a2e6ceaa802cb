#include "alloc_counter.hpp"

#include <atomic>
#include <cstddef>

#if defined(__SANITIZE_ADDRESS__)
// ASan owns malloc (interposing it here crashes its start-up): count through its allocator hook,
// which sees every allocation, malloc and operator new alike.
// From compiler-rt's <sanitizer/allocator_interface.h> (clang ships it, GCC does not).
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));
#endif

#if !defined(__SANITIZE_ADDRESS__) && !defined(_WIN32)
// Eigen allocates with std::malloc directly (not operator new), so the count is taken at malloc:
// this executable's malloc family interposes glibc's and forwards to glibc's own entry points.
// libstdc++'s operator new calls malloc, so containers are counted too.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
}
#endif

namespace {
std::atomic<std::size_t> g_allocations{0};
}

namespace ikchain {
namespace test {
std::size_t allocation_count() { return g_allocations.load(std::memory_order_relaxed); }
}  // namespace test
}  // namespace ikchain

#if defined(__SANITIZE_ADDRESS__)
namespace {
void count_allocation(const volatile void*, std::size_t) { g_allocations.fetch_add(1, std::memory_order_relaxed); }
void ignore_free(const volatile void*) {}
[[maybe_unused]] const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(count_allocation, ignore_free);
}  // namespace
#elif defined(_WIN32)
// Windows (mingw-w64, scripts/test runs it under wine): malloc is msvcrt.dll's, reached through an
// import stub that cannot be replaced by a definition of the same name (the import library's
// member defines it too). The test executable is linked with -Wl,--wrap=malloc,--wrap=calloc,
// --wrap=realloc (SConstruct, windows_tests), so every call in the executable, Eigen's and the
// statically linked libstdc++'s operator new's included, lands here; __real_* is the CRT's.
// msvcrt has no posix_memalign/aligned_alloc, and Eigen does not use _aligned_malloc on x86-64
// (malloc is 16-byte aligned there).
extern "C" {
void* __real_malloc(std::size_t);
void* __real_calloc(std::size_t, std::size_t);
void* __real_realloc(void*, std::size_t);
void* __wrap_malloc(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __real_malloc(size);
}
void* __wrap_calloc(std::size_t n, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __real_calloc(n, size);
}
void* __wrap_realloc(void* p, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __real_realloc(p, size);
}
}
#else
extern "C" {
void* malloc(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  *out = __libc_memalign(alignment, size);
  return *out ? 0 : 12;  // ENOMEM
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(alignment, size);
}
void free(void* p) { __libc_free(p); }
}
#endif
