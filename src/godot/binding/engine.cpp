#include "binding/classes.hpp"

#include <cstdio>

namespace ikchain::gdx {
namespace {

// Opaque engine handles, valid from SCENE init on (no engine objects, so safe as plain statics).
GDExtensionMethodBindPtr g_binds[int(gen::Method::Count)] = {};
void* g_tags[int(ClassTag::Count)] = {};

}  // namespace

bool init_method_binds() {
  bool ok = true;
  for (int i = 0; i < int(gen::Method::Count); ++i) {
    const gen::MethodId& id = gen::kMethods[i];
    const StringName cls(id.class_name);
    const StringName method(id.method);
    g_binds[i] = gde.classdb_get_method_bind(cls.ptr(), method.ptr(), id.hash);
    if (g_binds[i] == nullptr) {
      std::fprintf(stderr, "IKChain: engine method %s.%s (hash %lld) not found\n", id.class_name, id.method,
                   static_cast<long long>(id.hash));
      ok = false;
    }
  }
  for (int i = 0; i < int(ClassTag::Count); ++i) {
    const StringName cls(kClassTagNames[i]);
    g_tags[i] = gde.classdb_get_class_tag(cls.ptr());
    ok = ok && g_tags[i] != nullptr;
  }
  return ok;
}

GDExtensionMethodBindPtr method_bind(gen::Method m) { return g_binds[int(m)]; }
void* class_tag(ClassTag tag) { return g_tags[int(tag)]; }

}  // namespace ikchain::gdx
