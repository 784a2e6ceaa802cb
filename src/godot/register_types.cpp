// The library's entry point (the only exported symbol, see libikchain.map) and class registration
// at the SCENE initialization level.
#include <gdextension_interface.h>

#include <cstdio>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "binding/engine.hpp"
#include "binding/interface.hpp"
#include "editor_help.hpp"
#include "ik_chain.hpp"

namespace {

using ikchain::gdx::gde;

// Created at SCENE init, destroyed at SCENE deinit (holds StringNames: never a static object).
ikchain::gdx::ClassRecord* g_ik_chain_record = nullptr;
GDExtensionInterfaceGetProcAddress g_get_proc_address = nullptr;

void initialize(void*, GDExtensionInitializationLevel level) {
  if (level == GDEXTENSION_INITIALIZATION_EDITOR) ikchain::godot::load_class_docs(g_get_proc_address);
  if (level != GDEXTENSION_INITIALIZATION_SCENE) return;
  if (!ikchain::gdx::init_builtins() || !ikchain::gdx::init_method_binds()) {
    std::fprintf(stderr, "IKChain: this engine lacks methods IKChain needs; IKChain is not registered.\n");
    return;
  }
  g_ik_chain_record = new ikchain::gdx::ClassRecord{ikchain::gdx::StringName("IKChain"),
                                                    ikchain::gdx::StringName("SkeletonModifier3D"), {}, {}};
  ikchain::godot::IKChain::register_class(*g_ik_chain_record);
}

void deinitialize(void*, GDExtensionInitializationLevel level) {
  if (level != GDEXTENSION_INITIALIZATION_SCENE || g_ik_chain_record == nullptr) return;
  gde.classdb_unregister_extension_class(gde.library, g_ik_chain_record->name.ptr());
  ikchain::godot::IKChain::unregister_class();
  delete g_ik_chain_record;
  g_ik_chain_record = nullptr;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) GDExtensionBool ikchain_library_init(
    GDExtensionInterfaceGetProcAddress get_proc_address, GDExtensionClassLibraryPtr library,
    GDExtensionInitialization* r_initialization) {
  if (!ikchain::gdx::load_interface(get_proc_address, library)) return 0;
  g_get_proc_address = get_proc_address;
  r_initialization->minimum_initialization_level = GDEXTENSION_INITIALIZATION_SCENE;
  r_initialization->userdata = nullptr;
  r_initialization->initialize = &initialize;
  r_initialization->deinitialize = &deinitialize;
  return 1;
}
