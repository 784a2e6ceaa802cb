#include "binding/interface.hpp"

#include <cstdio>

namespace ikchain::gdx {

Interface gde;

bool load_interface(GDExtensionInterfaceGetProcAddress get_proc_address, GDExtensionClassLibraryPtr library) {
  gde.library = library;
  bool ok = true;
#define IKCHAIN_GDX_LOAD(member, name, type)                                          \
  gde.member = reinterpret_cast<type>(get_proc_address(name));                        \
  if (gde.member == nullptr) {                                                        \
    std::fprintf(stderr, "IKChain: GDExtension interface function '%s' missing\n", name); \
    ok = false;                                                                       \
  }
  IKCHAIN_GDX_INTERFACE_FUNCTIONS(IKCHAIN_GDX_LOAD)
#undef IKCHAIN_GDX_LOAD
  return ok;
}

}  // namespace ikchain::gdx
