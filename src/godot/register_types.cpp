// The library's entry point (the only exported symbol, see libikchain.map) and class registration
// at the SCENE initialization level.
#include <gdextension_interface.h>

#include <cstdio>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "binding/engine.hpp"
#include "binding/interface.hpp"
#include "editor_help.hpp"
#include "ik_body.hpp"
#include "ik_body_effector.hpp"
#include "ik_chain.hpp"
#include "ik_chain_goal.hpp"
#include "ik_chain_joint.hpp"
#include "ik_modifier.hpp"

namespace {

using ikchain::gdx::gde;

namespace gdx = ikchain::gdx;

// Created at SCENE init, destroyed at SCENE deinit (they hold StringNames: never static objects).
// Resources first: IKChain's properties name them.
gdx::ClassRecord* g_joint_record = nullptr;
gdx::ClassRecord* g_goal_record = nullptr;
gdx::ClassRecord* g_ik_chain_record = nullptr;
gdx::ClassRecord* g_effector_record = nullptr;
gdx::ClassRecord* g_ik_body_record = nullptr;

gdx::ClassRecord* new_record(const char* name, const char* parent) {
  return new gdx::ClassRecord{gdx::StringName(name), gdx::StringName(parent), {}, {}};
}

void unregister(gdx::ClassRecord*& record) {
  if (record == nullptr) return;
  gde.classdb_unregister_extension_class(gde.library, record->name.ptr());
  delete record;
  record = nullptr;
}
GDExtensionInterfaceGetProcAddress g_get_proc_address = nullptr;

void initialize(void*, GDExtensionInitializationLevel level) {
  if (level == GDEXTENSION_INITIALIZATION_EDITOR) ikchain::godot::load_class_docs(g_get_proc_address);
  if (level != GDEXTENSION_INITIALIZATION_SCENE) return;
  if (!ikchain::gdx::init_builtins() || !ikchain::gdx::init_method_binds()) {
    std::fprintf(stderr, "IKChain: this engine lacks methods IKChain needs; IKChain is not registered.\n");
    return;
  }
  ikchain::godot::IKModifier::register_names();
  g_joint_record = new_record("IKChainJoint", "Resource");
  ikchain::godot::IKChainJoint::register_class(*g_joint_record);
  g_goal_record = new_record("IKChainGoal", "Resource");
  ikchain::godot::IKChainGoal::register_class(*g_goal_record);
  g_ik_chain_record = new_record("IKChain", "SkeletonModifier3D");
  ikchain::godot::IKChain::register_class(*g_ik_chain_record);
  g_effector_record = new_record("IKBodyEffector", "Resource");
  ikchain::godot::IKBodyEffector::register_class(*g_effector_record);
  g_ik_body_record = new_record("IKBody", "SkeletonModifier3D");
  ikchain::godot::IKBody::register_class(*g_ik_body_record);
}

void deinitialize(void*, GDExtensionInitializationLevel level) {
  if (level != GDEXTENSION_INITIALIZATION_SCENE || g_ik_chain_record == nullptr) return;
  unregister(g_ik_body_record);  // reverse order of registration
  ikchain::godot::IKBody::unregister_class();
  unregister(g_effector_record);
  unregister(g_ik_chain_record);
  ikchain::godot::IKChain::unregister_class();
  unregister(g_goal_record);
  unregister(g_joint_record);
  ikchain::godot::IKModifier::unregister_names();
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
